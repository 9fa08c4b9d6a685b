#include "server/http_routes.hpp"

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "google/api/annotations.pb.h"
#include "google/protobuf/util/json_util.h"
#include "server/store/absl_view.hpp"

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
        if (field.find_first_of("=*.") != std::string::npos) {
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

int HexValue(char c) {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}

absl::StatusOr<std::string> PercentDecode(std::string_view text, bool plus_is_space = false) {
    std::string out;
    for (std::size_t i = 0; i < text.size(); ++i) {
        if (text[i] != '%') {
            out += plus_is_space && text[i] == '+' ? ' ' : text[i];
            continue;
        }
        const int hi = i + 2 < text.size() ? HexValue(text[i + 1]) : -1;
        const int lo = i + 2 < text.size() ? HexValue(text[i + 2]) : -1;
        if (hi < 0 || lo < 0) {
            return absl::InvalidArgumentError(
                absl::StrCat("bad percent-encoding in '", AbslView(text.substr(0, 200)), "'"));
        }
        out += static_cast<char>(hi * 16 + lo);
        i += 2;
    }
    return out;
}

/// Sets a scalar field of `message` from a path or query value.
absl::Status SetField(google::protobuf::Message* message, const std::string& name,
                      const std::string& value) {
    const google::protobuf::Descriptor* descriptor = message->GetDescriptor();
    const google::protobuf::FieldDescriptor* field = descriptor->FindFieldByName(name);
    if (field == nullptr) field = descriptor->FindFieldByCamelcaseName(name);
    if (field == nullptr || field->is_repeated() ||
        field->cpp_type() == google::protobuf::FieldDescriptor::CPPTYPE_MESSAGE) {
        return absl::InvalidArgumentError(absl::StrCat("unknown parameter '", name, "'"));
    }
    const google::protobuf::Reflection* reflection = message->GetReflection();
    using F = google::protobuf::FieldDescriptor;
    bool ok = true;
    switch (field->cpp_type()) {
        case F::CPPTYPE_STRING: {
            if (reflection->HasField(*message, field) &&
                reflection->GetString(*message, field) != value) {
                return absl::InvalidArgumentError(absl::StrCat(
                    field->name(), ": the body says '", reflection->GetString(*message, field),
                    "' but the path says '", value, "'"));
            }
            reflection->SetString(message, field, value);
            break;
        }
        case F::CPPTYPE_BOOL: {
            ok = value == "true" || value == "false";
            if (ok) reflection->SetBool(message, field, value == "true");
            break;
        }
        case F::CPPTYPE_DOUBLE: {
            double number = 0.0;
            ok = absl::SimpleAtod(value, &number);
            if (ok) reflection->SetDouble(message, field, number);
            break;
        }
        case F::CPPTYPE_INT32: {
            int number = 0;
            ok = absl::SimpleAtoi(value, &number);
            if (ok) reflection->SetInt32(message, field, number);
            break;
        }
        default:
            return absl::InvalidArgumentError(
                absl::StrCat("parameter '", name, "' cannot be set from the URL"));
    }
    if (!ok) {
        return absl::InvalidArgumentError(
            absl::StrCat(field->name(), ": '", value, "' is not a valid value"));
    }
    return absl::OkStatus();
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

absl::StatusOr<std::vector<std::pair<std::string, std::string>>> ParseQuery(
    std::string_view query) {
    std::vector<std::pair<std::string, std::string>> pairs;
    for (absl::string_view absl_part : absl::StrSplit(AbslView(query), '&', absl::SkipEmpty())) {
        const std::string_view part(absl_part.data(), absl_part.size());
        const std::size_t equals = part.find('=');
        absl::StatusOr<std::string> name = PercentDecode(part.substr(0, equals), true);
        if (!name.ok()) return name.status();
        absl::StatusOr<std::string> value =
            PercentDecode(equals == std::string_view::npos ? "" : part.substr(equals + 1), true);
        if (!value.ok()) return value.status();
        pairs.emplace_back(*std::move(name), *std::move(value));
    }
    return pairs;
}

absl::Status BindRequest(const HttpRoute& route, const std::map<std::string, std::string>& path,
                         std::string_view query, const std::string& body,
                         google::protobuf::Message* message) {
    if (route.body == "*" && !body.empty()) {
        google::protobuf::util::JsonParseOptions options;
        options.ignore_unknown_fields = true;  // as grpc-gateway: newer clients, older servers
        const auto parsed = google::protobuf::util::JsonStringToMessage(body, message, options);
        if (!parsed.ok()) {
            return absl::InvalidArgumentError(
                absl::StrCat("request body: ", std::string(parsed.message())));
        }
    }
    for (const auto& [field, value] : path) {
        if (absl::Status status = SetField(message, field, value); !status.ok()) return status;
    }
    absl::StatusOr<std::vector<std::pair<std::string, std::string>>> parameters = ParseQuery(query);
    if (!parameters.ok()) return parameters.status();
    for (const auto& [name, value] : *parameters) {
        if (route.body == "*") {
            return absl::InvalidArgumentError(absl::StrCat("unknown parameter '", name, "'"));
        }
        if (absl::Status status = SetField(message, name, value); !status.ok()) return status;
    }
    return absl::OkStatus();
}

}  // namespace soilvol::server
