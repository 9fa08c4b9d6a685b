#include "server/http/http_routes.hpp"

#include <utility>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "google/api/annotations.pb.h"
#include "server/http/query_string.hpp"

namespace soilvol::server {
namespace {

std::string RegexEscape(const std::string& text) {
    static const std::string kSpecial = R"(\^$.|?*+()[]{})";
    std::string out;
    for (const char c : text) {
        if (kSpecial.find(c) != std::string::npos) out += '\\';
        out += c;
    }
    return out;
}

absl::StatusOr<HttpRoute> MakeRoute(const std::string& method, const std::string& verb,
                                    const std::string& pattern, const std::string& body) {
    HttpRoute route{verb, pattern, method, body, {}, {}};
    std::string regex = "^";
    std::size_t at = 0;
    while (at < pattern.size()) {
        const std::size_t open = pattern.find('{', at);
        if (open == std::string::npos) {
            regex += RegexEscape(pattern.substr(at));
            break;
        }
        const std::size_t close = pattern.find('}', open);
        if (close == std::string::npos) {
            return absl::InvalidArgumentError(absl::StrCat(method, ": unclosed '{' in ", pattern));
        }
        const std::string field = pattern.substr(open + 1, close - open - 1);
        if (field.find_first_of("=*") != std::string::npos) {
            return absl::InvalidArgumentError(
                absl::StrCat(method, ": unsupported path variable {", field, "}"));
        }
        regex += RegexEscape(pattern.substr(at, open - at)) + "([^/:]+)";
        route.path_fields.push_back(field);
        at = close + 1;
    }
    route.regex = std::regex(regex + "$");
    return route;
}

}  // namespace

absl::StatusOr<std::vector<HttpRoute>> RoutesFromAnnotations(
    const google::protobuf::ServiceDescriptor& service) {
    std::vector<HttpRoute> routes;
    for (int i = 0; i < service.method_count(); ++i) {
        const google::protobuf::MethodDescriptor& method = *service.method(i);
        if (!method.options().HasExtension(google::api::http)) continue;
        const google::api::HttpRule& rule = method.options().GetExtension(google::api::http);
        std::pair<std::string, std::string> verb_pattern;
        switch (rule.pattern_case()) {
            case google::api::HttpRule::kGet:
                verb_pattern = {"GET", rule.get()};
                break;
            case google::api::HttpRule::kPost:
                verb_pattern = {"POST", rule.post()};
                break;
            case google::api::HttpRule::kPut:
                verb_pattern = {"PUT", rule.put()};
                break;
            case google::api::HttpRule::kPatch:
                verb_pattern = {"PATCH", rule.patch()};
                break;
            case google::api::HttpRule::kDelete:
                verb_pattern = {"DELETE", rule.delete_()};
                break;
            default:
                return absl::InvalidArgumentError(
                    absl::StrCat(method.name(), ": unsupported google.api.http pattern"));
        }
        absl::StatusOr<HttpRoute> route =
            MakeRoute(method.name(), verb_pattern.first, verb_pattern.second, rule.body());
        if (!route.ok()) return route.status();
        routes.push_back(*std::move(route));
    }
    return routes;
}

absl::StatusOr<RouteMatch> MatchRoute(const std::vector<HttpRoute>& routes, const std::string& verb,
                                      const std::string& path) {
    bool path_known = false;
    for (const HttpRoute& route : routes) {
        std::smatch groups;
        if (!std::regex_match(path, groups, route.regex)) continue;
        path_known = true;
        if (route.verb != verb) continue;
        RouteMatch match{&route, {}};
        for (std::size_t i = 0; i < route.path_fields.size(); ++i) {
            absl::StatusOr<std::string> value = PercentDecode(groups[i + 1].str());
            if (!value.ok()) return value.status();
            match.fields[route.path_fields[i]] = *std::move(value);
        }
        return match;
    }
    if (path_known) {
        return absl::UnimplementedError(absl::StrCat("method ", verb, " is not allowed on ", path));
    }
    return absl::NotFoundError(absl::StrCat("no route for ", verb, " ", path));
}

std::optional<std::pair<std::string, std::string>> HeightmapPngIds(const std::string& path) {
    static const std::regex kPath(R"(^/v1/containers/([^/:]+)/estimates/([^/:]+)/heightmap\.png$)");
    std::smatch groups;
    if (!std::regex_match(path, groups, kPath)) return std::nullopt;
    return std::make_pair(groups[1].str(), groups[2].str());
}

std::optional<ExportPath> ExportPathOf(const std::string& path, const std::string& query) {
    constexpr std::string_view kSuffix = ":export";
    if (path.size() <= kSuffix.size() ||
        path.compare(path.size() - kSuffix.size(), kSuffix.size(), kSuffix) != 0) {
        return std::nullopt;
    }
    ExportPath out{path.substr(0, path.size() - kSuffix.size()), "", "csv"};
    for (const absl::string_view part : absl::StrSplit(query, '&', absl::SkipEmpty())) {
        if (absl::StartsWith(part, "format=")) {
            out.format = std::string(part.substr(7));
            continue;
        }
        absl::StrAppend(&out.query, out.query.empty() ? "" : "&", part);
    }
    return out;
}

}  // namespace soilvol::server
