#pragma once

#include <string_view>

namespace soilvol::proto {

/// The REST gateway's OpenAPI (Swagger 2.0) document, generated from the proto at build time
/// (cmake/OpenApi.cmake) and served at GET /openapi.json.
std::string_view OpenApiDocument();

}  // namespace soilvol::proto
