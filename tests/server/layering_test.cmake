# CTest script: the include check the build runs (cmake/CheckLayering.cmake with the rules of
# cmake/Layering.cmake, as configured in <build>/layering/rules.cmake) fails on a forbidden
# include and passes the allowed ones. For every layer: a copy of the layer's own files passes;
# the same copy with one forbidden include added fails, naming the file and the include.
#   -DRULES=<build>/layering/rules.cmake -DCHECK=<cmake/CheckLayering.cmake>
#   -DSOURCE=<project root> -DWORK=<scratch dir>
cmake_minimum_required(VERSION 3.22)
include(${RULES})
set(probes
    "core=grpcpp/grpcpp.h"
    "core=server/base/logging.hpp"
    "proto/convert=boost/beast/http.hpp"
    "server/base=server/store/entry_store.hpp"
    "server/store=server/records/record_store.hpp"
    "server/records=server/handlers/soilvol_handlers.hpp"
    "server/auth=server/dispatch/dispatcher.hpp"
    "server/handlers=boost/beast/http.hpp"
    "server/handlers=grpcpp/grpcpp.h"
    "server/handlers=server/http/http_server.hpp"
    "server/handlers=server/dispatch/dispatcher.hpp"
    "server/handlers=server/server.hpp"
    "server/dispatch=server/grpc/grpc_service.hpp"
    "server/grpc=boost/asio/ip/tcp.hpp"
    "server/http=grpcpp/grpcpp.h"
    "server/dashboard=server/base/logging.hpp")
set(allowed
    "server/handlers=server/store/entry_store.hpp"
    "server/handlers=server/records/recorder.hpp"
    "server/dispatch=server/handlers/call_record.hpp"
    "server/http=boost/beast/http.hpp"
    "server/grpc=grpcpp/grpcpp.h")

function(run_check layer dir expect_failure what)
    execute_process(
        COMMAND ${CMAKE_COMMAND} -DSOURCE_DIR=${dir} -DLAYER=${layer}
                "-DFORBIDDEN=${SOILVOL_LAYER_${layer}}" -DSTAMP=${WORK}/stamp -P ${CHECK}
        RESULT_VARIABLE result OUTPUT_VARIABLE out ERROR_VARIABLE err)
    if(expect_failure AND result EQUAL 0)
        message(FATAL_ERROR "${layer}: ${what} passed the check")
    endif()
    if(NOT expect_failure AND NOT result EQUAL 0)
        message(FATAL_ERROR "${layer}: ${what} failed the check:\n${err}")
    endif()
    set(check_output "${err}" PARENT_SCOPE)
endfunction()

foreach(layer IN LISTS SOILVOL_LAYERS)
    file(REMOVE_RECURSE ${WORK})
    file(COPY ${SOURCE}/${layer}/ DESTINATION ${WORK}/tree)
    run_check(${layer} ${WORK}/tree FALSE "its own files")
endforeach()

foreach(probe IN LISTS probes allowed)
    string(REPLACE "=" ";" parts "${probe}")
    list(GET parts 0 layer)
    list(GET parts 1 header)
    if(NOT DEFINED SOILVOL_LAYER_${layer})
        message(FATAL_ERROR "no layering rule for ${layer}")
    endif()
    file(REMOVE_RECURSE ${WORK})
    file(COPY ${SOURCE}/${layer}/ DESTINATION ${WORK}/tree)
    file(WRITE ${WORK}/tree/probe.cpp "#include \"${header}\"\n")
    if(probe IN_LIST probes)
        run_check(${layer} ${WORK}/tree TRUE "#include \"${header}\"")
        if(NOT check_output MATCHES "probe\\.cpp" OR NOT check_output MATCHES "${header}")
            message(FATAL_ERROR "${layer}: the failure does not name probe.cpp and ${header}:\n"
                                "${check_output}")
        endif()
    else()
        run_check(${layer} ${WORK}/tree FALSE "#include \"${header}\"")
    endif()
endforeach()
file(REMOVE_RECURSE ${WORK})
list(LENGTH probes n)
message(STATUS "layering: every layer passes its own files; ${n} forbidden includes fail")
