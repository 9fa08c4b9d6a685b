#pragma once

#include <map>
#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "google/protobuf/message.h"
#include "server/http/http_routes.hpp"

namespace soilvol::server {

/// How a request body is encoded, from its Content-Type.
enum class BodyKind {
    kJson,    ///< application/json: the request as proto3 JSON
    kBinary,  ///< application/octet-stream: one file (query file=cloud|mesh); the rest in the query
    kMultipart,  ///< multipart/form-data: a `request` JSON part, files cloud / left / right / mesh
    kOther,
};
BodyKind BodyKindOf(std::string_view content_type);

/// Fills `message` (the route's request message) as grpc-gateway does - the body as proto3 JSON
/// when the route takes one (body "*"; unknown fields ignored), the path values, then the query
/// parameters (fields by dotted proto or JSON name; none beside a JSON body) - and, for routes
/// whose request carries a `scan` or a `mesh`, from a binary or multipart body (BodyKind): a
/// binary body's bytes move into scan.cloud.data, or mesh.data with the query parameter
/// file=mesh (`body` is left empty); multipart file parts cloud, left, right and mesh fill
/// scan.cloud.data, scan.stereo.left/right and mesh.data. Files are bound last. A query
/// parameter or part naming a message field takes its proto3 JSON. InvalidArgument naming the
/// field or parameter at fault.
absl::Status BindRequest(const HttpRoute& route, const std::map<std::string, std::string>& path,
                         std::string_view query, std::string_view content_type, std::string& body,
                         google::protobuf::Message* message);

}  // namespace soilvol::server
