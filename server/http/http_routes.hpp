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

/// The container and estimate ids of GET /v1/containers/{container_id}/estimates/
/// {estimate_id}/heightmap.png (no proto route: a PNG, not JSON); nullopt for any other path.
std::optional<std::pair<std::string, std::string>> HeightmapPngIds(const std::string& path);

/// An export (GET <list path>:export?format=csv|jsonl&<the list's filters>): the list route's
/// path, and the query without `format` and the format given ("csv" when none); nullopt for a
/// path that does not end in ":export".
struct ExportPath {
    std::string list_path;
    std::string query;
    std::string format;
};
std::optional<ExportPath> ExportPathOf(const std::string& path, const std::string& query);

}  // namespace soilvol::server
