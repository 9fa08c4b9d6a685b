# One warnings policy for every soilvol target (STYLE.md rule 8).
function(soilvol_set_warnings target)
    target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor
                                             -Wold-style-cast -Wcast-align -Wunused -Woverloaded-virtual
                                             -Wnull-dereference -Wdouble-promotion -Wformat=2)
    if(SOILVOL_WARNINGS_AS_ERRORS)
        target_compile_options(${target} PRIVATE -Werror)
    endif()
endfunction()

# soilvol_unity_build(<target>): compile the target's files in batches of six (CMake's unity
# build). For the server, the client and their tests, whose every file includes the gRPC stubs,
# protobuf, Beast or CLI11: those headers took most of each file's compile time, and batches
# parse them once per batch (the client: 113 s -> 44 s of CPU on two cores). Files stay free of
# name clashes across a batch: no two share a name in an anonymous namespace.
function(soilvol_unity_build target)
    set_target_properties(${target} PROPERTIES UNITY_BUILD ON UNITY_BUILD_BATCH_SIZE 6)
endfunction()
