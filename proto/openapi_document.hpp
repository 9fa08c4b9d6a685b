#pragma once

#include <string_view>

namespace soilvol::proto {

/// The REST gateway's OpenAPI 3.0 document (proto/openapi/soilvol.v1.openapi.json, made from the
/// proto by scripts/gen-openapi.sh, embedded by cmake/OpenApi.cmake), served at GET /openapi.json.
std::string_view OpenApiDocument();

}  // namespace soilvol::proto
