# soilvol_build_info: the version, git revision, build type, compiler and library versions,
# fixed at configure time (re-run cmake, as scripts/build.sh does, to refresh the revision).
find_package(Git QUIET)
set(SOILVOL_REVISION unknown)
if(GIT_FOUND AND EXISTS ${PROJECT_SOURCE_DIR}/.git)
    execute_process(COMMAND ${GIT_EXECUTABLE} describe --always --dirty --tags
                    WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}
                    OUTPUT_VARIABLE git_revision OUTPUT_STRIP_TRAILING_WHITESPACE
                    RESULT_VARIABLE git_result ERROR_QUIET)
    if(git_result EQUAL 0 AND git_revision)
        set(SOILVOL_REVISION ${git_revision})
    endif()
endif()
set(SOILVOL_BUILD_TYPE ${CMAKE_BUILD_TYPE})
if(NOT SOILVOL_BUILD_TYPE)
    set(SOILVOL_BUILD_TYPE "none")
endif()
set(versions)
foreach(pair "eigen;${Eigen3_VERSION}" "pcl;${PCL_VERSION}" "opencv;${OpenCV_VERSION}"
             "protobuf;${Protobuf_VERSION}" "grpc;${gRPC_VERSION}")
    list(GET pair 0 name)
    list(LENGTH pair n)
    if(n GREATER 1)
        list(GET pair 1 version)
        string(APPEND versions "{\"${name}\", \"${version}\"}, ")
    endif()
endforeach()
set(SOILVOL_LIBRARY_VERSIONS ${versions})
configure_file(${PROJECT_SOURCE_DIR}/core/common/build_info.cpp.in
               ${CMAKE_BINARY_DIR}/generated/build_info.cpp @ONLY)
add_library(soilvol_build_info STATIC ${CMAKE_BINARY_DIR}/generated/build_info.cpp)
target_include_directories(soilvol_build_info PUBLIC ${PROJECT_SOURCE_DIR})
