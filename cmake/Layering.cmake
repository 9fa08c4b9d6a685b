# The direction of soilvol's layers, checked on every build (cmake/CheckLayering.cmake): a file
# that includes what its layer may not see fails the build, naming the file and the include.
#
#   core/*            the method: no gRPC, protobuf, HTTP, metrics or server headers
#   proto/convert     proto <-> core; no server, client or transport
#   server/base       logging, status mapping, POSIX I/O, call ids: no other server layer
#   server/store      container models and calibrations on disk: base only
#   server/records    estimate records (SQLite, PostgreSQL): base and store only
#   server/auth       tokens and scopes: base only
#   server/handlers   the RPCs over core, store and records: never Beast, asio or the gRPC
#                     server API, never a transport, the dispatcher or auth
#   server/dispatch   the worker pool, metrics and the call log: handlers, auth, base; no transport
#   server/grpc       the gRPC transport: no HTTP
#   server/http       the REST transport: no gRPC server API
#   server/dashboard  static files: nothing of the server
#
# soilvol_check_layering(<layer name> <dir> <forbidden include regex>): a target
# soilvol_layering_<layer as an identifier> that the layer's libraries depend on.
set(SOILVOL_TRANSPORT_HEADERS "grpc/|grpcpp/|boost/beast|boost/asio|httplib")
set(SOILVOL_SERVER_LAYERS "auth|base|dashboard|dispatch|grpc|handlers|http|records|store")

function(soilvol_check_layering layer dir forbidden)
    string(MAKE_C_IDENTIFIER "${layer}" id)
    file(GLOB_RECURSE files CONFIGURE_DEPENDS ${dir}/*.hpp ${dir}/*.cpp)
    set(stamp ${CMAKE_BINARY_DIR}/layering/${id}.stamp)
    add_custom_command(
        OUTPUT ${stamp}
        COMMAND ${CMAKE_COMMAND} -DSOURCE_DIR=${dir} -DLAYER=${layer} -DFORBIDDEN=${forbidden}
                -DSTAMP=${stamp} -P ${PROJECT_SOURCE_DIR}/cmake/CheckLayering.cmake
        DEPENDS ${PROJECT_SOURCE_DIR}/cmake/CheckLayering.cmake ${files}
        COMMENT "Checking the includes of ${layer}"
        VERBATIM)
    add_custom_target(soilvol_layering_${id} DEPENDS ${stamp})
endfunction()

# soilvol_server_layer(<folder> <server layers it may include, a|b> <other forbidden headers>):
# the check of server/<folder> (target soilvol_layering_server_<folder>).
function(soilvol_server_layer folder allowed_layers forbidden_headers)
    string(REPLACE "|" ";" all "${SOILVOL_SERVER_LAYERS}")
    set(others "")
    foreach(layer IN LISTS all)
        if(NOT layer STREQUAL folder AND NOT "|${allowed_layers}|" MATCHES "\\|${layer}\\|")
            list(APPEND others ${layer})
        endif()
    endforeach()
    string(REPLACE ";" "|" others "${others}")
    set(forbidden "server/(${others})/|server/(server|options)\\.hpp")
    if(forbidden_headers)
        set(forbidden "${forbidden}|${forbidden_headers}")
    endif()
    soilvol_check_layering("server/${folder}" ${PROJECT_SOURCE_DIR}/server/${folder}
                           "${forbidden}")
endfunction()
