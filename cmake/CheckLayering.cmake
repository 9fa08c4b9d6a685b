# Fails the build when a file of one layer includes a header its layer may not see (STYLE.md
# rule 1; the rules are in cmake/Layering.cmake, one per folder of core/ and server/).
# Run as: cmake -DSOURCE_DIR=<dir> -DLAYER=<name> -DFORBIDDEN=<regex of include paths>
#               -DSTAMP=<file> -P CheckLayering.cmake
# The regex is matched against what follows `#include <` or `#include "`, e.g.
# "boost/beast|grpcpp|server/http/". A missing stamp, never an old one, follows a failure.
foreach(var SOURCE_DIR LAYER FORBIDDEN STAMP)
    if(NOT DEFINED ${var})
        message(FATAL_ERROR "CheckLayering.cmake needs -D${var}=")
    endif()
endforeach()
file(REMOVE "${STAMP}")
file(GLOB_RECURSE layer_files "${SOURCE_DIR}/*.hpp" "${SOURCE_DIR}/*.cpp")
set(violations "")
foreach(f IN LISTS layer_files)
    file(STRINGS "${f}" lines REGEX "^[ \t]*#[ \t]*include[ \t]*[<\"](${FORBIDDEN})")
    foreach(line IN LISTS lines)
        file(RELATIVE_PATH shown "${SOURCE_DIR}" "${f}")
        string(STRIP "${line}" line)
        list(APPEND violations "  ${shown}: ${line}")
    endforeach()
endforeach()
if(violations)
    string(REPLACE ";" "\n" msg "${violations}")
    message(FATAL_ERROR "layering: ${LAYER} may not include (${FORBIDDEN}):\n${msg}")
endif()
file(TOUCH "${STAMP}")
