#pragma once

#include <map>
#include <optional>
#include <regex>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"
#include "google/protobuf/descriptor.h"
#include "google/protobuf/message.h"

namespace soilvol::server {

/// One REST route, read from a method's google.api.http annotation.
struct HttpRoute {
    std::string verb;                      ///< GET, POST, PUT, PATCH or DELETE
    std::string pattern;                   ///< "/v1/containers/{container_id}:estimate"
    std::string method;                    ///< RPC name: "EstimateVolume"
    std::string body;                      ///< "*" (the whole request) or "" (none)
    std::vector<std::string> path_fields;  ///< request fields bound by the path, in order
    std::regex regex;                      ///< matches the path, one group per path field
};

/// A path matched to a route: the route and its decoded path values.
struct RouteMatch {
    const HttpRoute* route = nullptr;
    std::map<std::string, std::string> fields;
};

/// The routes of every method of `service` that has a google.api.http annotation.
/// InvalidArgument for a template this gateway does not support (nested fields, wildcards).
absl::StatusOr<std::vector<HttpRoute>> RoutesFromAnnotations(
    const google::protobuf::ServiceDescriptor& service);

/// The route for `verb` and `path` (query string removed); NotFound when no route has the
/// path, Unimplemented (405) when routes have it for other verbs, InvalidArgument for a path
/// value that is not valid percent-encoding.
absl::StatusOr<RouteMatch> MatchRoute(const std::vector<HttpRoute>& routes, const std::string& verb,
                                      const std::string& path);

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

/// The name=value pairs of a query string (after '?'), percent-decoded, '+' read as a space;
/// a name without '=' has the value "". InvalidArgument for bad percent-encoding.
absl::StatusOr<std::vector<std::pair<std::string, std::string>>> ParseQuery(std::string_view query);

}  // namespace soilvol::server
