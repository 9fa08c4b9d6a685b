#include "server/http_routes.hpp"

#include <algorithm>
#include <array>
#include <cstring>
#include <set>

#include "absl/strings/ascii.h"
#include "absl/strings/escaping.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "core/common/status_macros.hpp"
#include "google/api/annotations.pb.h"
#include "google/protobuf/field_mask.pb.h"
#include "google/protobuf/struct.pb.h"
#include "google/protobuf/util/json_util.h"
#include "server/multipart.hpp"
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

const google::protobuf::FieldDescriptor* FindField(const google::protobuf::Descriptor& type,
                                                   const std::string& name) {
    const google::protobuf::FieldDescriptor* field = type.FindFieldByName(name);
    return field != nullptr ? field : type.FindFieldByCamelcaseName(name);
}

/// Protobuf's JSON parser ends its message with a window of the input and a line with a caret
/// under the fault ("reason.\n<input window>\n    ^"), newlines of the input included. A client
/// reads one line: the reason, and where in the body it broke as line, column and byte.
std::string ReadableJsonError(std::string_view json, std::string_view message) {
    const std::size_t first = message.find('\n');
    const std::size_t last = message.rfind('\n');
    std::string_view reason = message.substr(0, first);
    while (!reason.empty() && (reason.back() == '.' || reason.back() == ' ')) {
        reason.remove_suffix(1);
    }
    if (first == std::string_view::npos || last <= first) return std::string(reason);
    const std::string_view window = message.substr(first + 1, last - first - 1);
    const std::size_t caret = message.find('^', last);
    const std::size_t at = json.find(window);
    if (caret == std::string_view::npos || at == std::string_view::npos) {
        return std::string(reason);
    }
    const std::size_t offset = std::min(json.size(), at + (caret - last - 1));
    const std::string_view before = json.substr(0, offset);
    const std::size_t line_start = before.rfind('\n');
    const std::size_t line =
        1 + static_cast<std::size_t>(std::count(before.begin(), before.end(), '\n'));
    const std::size_t column =
        offset - (line_start == std::string_view::npos ? 0 : line_start + 1) + 1;
    return absl::StrFormat("%s at line %d, column %d (byte %d)", reason, line, column, offset);
}

absl::Status ParseJsonInto(std::string_view json, google::protobuf::Message* message,
                           const std::string& what) {
    google::protobuf::util::JsonParseOptions options;
    options.ignore_unknown_fields = true;  // as grpc-gateway: newer clients, older servers
    const auto parsed = google::protobuf::util::JsonStringToMessage(
        google::protobuf::StringPiece(json.data(), json.size()), message, options);
    if (!parsed.ok()) {
        return absl::InvalidArgumentError(
            absl::StrCat(what, ": ", ReadableJsonError(json, std::string(parsed.message()))));
    }
    return absl::OkStatus();
}

/// Sets the field a path value or query parameter names (grpc-gateway's rules: a dotted path
/// of singular message fields to a scalar or enum, repeated scalars appended), or - where a
/// query cannot express it - a message field from its proto3 JSON.
absl::Status SetField(google::protobuf::Message* message, const std::string& name,
                      const std::string& value) {
    using F = google::protobuf::FieldDescriptor;
    const F* field = nullptr;
    std::string path;
    for (absl::string_view step : absl::StrSplit(AbslView(name), '.')) {
        if (field != nullptr) {
            if (field->is_repeated() || field->cpp_type() != F::CPPTYPE_MESSAGE) {
                return absl::InvalidArgumentError(absl::StrCat("unknown parameter '", name, "'"));
            }
            message = message->GetReflection()->MutableMessage(message, field);
        }
        field = FindField(*message->GetDescriptor(), std::string(step));
        if (field == nullptr) {
            return absl::InvalidArgumentError(absl::StrCat("unknown parameter '", name, "'"));
        }
        absl::StrAppend(&path, path.empty() ? "" : ".", field->name());
    }
    const google::protobuf::Reflection* reflection = message->GetReflection();
    if (field->cpp_type() == F::CPPTYPE_MESSAGE) {
        google::protobuf::Message* target = field->is_repeated()
                                                ? reflection->AddMessage(message, field)
                                                : reflection->MutableMessage(message, field);
        // FieldMask, Timestamp and Duration are JSON strings; a query gives them bare
        // (?update_mask=displayName,labels), as grpc-gateway takes them.
        const std::string& type = field->message_type()->full_name();
        const bool string_form = type == "google.protobuf.FieldMask" ||
                                 type == "google.protobuf.Timestamp" ||
                                 type == "google.protobuf.Duration";
        if (string_form && (value.empty() || value.front() != '"')) {
            return ParseJsonInto(absl::StrCat("\"", absl::CEscape(value), "\""), target, path);
        }
        return ParseJsonInto(value, target, path);
    }
    const bool repeated = field->is_repeated();
    bool ok = true;
    switch (field->cpp_type()) {
        case F::CPPTYPE_STRING: {
            if (field->type() == F::TYPE_BYTES) {
                return absl::InvalidArgumentError(
                    absl::StrCat(path, ": bytes cannot be set from the URL"));
            }
            if (!repeated && reflection->HasField(*message, field) &&
                reflection->GetString(*message, field) != value) {
                return absl::InvalidArgumentError(
                    absl::StrCat(path, ": the body says '", reflection->GetString(*message, field),
                                 "' but the URL says '", value, "'"));
            }
            repeated ? reflection->AddString(message, field, value)
                     : reflection->SetString(message, field, value);
            break;
        }
        case F::CPPTYPE_BOOL: {
            ok = value == "true" || value == "false";
            if (ok && repeated) reflection->AddBool(message, field, value == "true");
            if (ok && !repeated) reflection->SetBool(message, field, value == "true");
            break;
        }
        case F::CPPTYPE_DOUBLE:
        case F::CPPTYPE_FLOAT: {
            double number = 0.0;
            ok = absl::SimpleAtod(value, &number);
            if (!ok) break;
            if (field->cpp_type() == F::CPPTYPE_FLOAT) {
                const auto narrow = static_cast<float>(number);
                repeated ? reflection->AddFloat(message, field, narrow)
                         : reflection->SetFloat(message, field, narrow);
            } else {
                repeated ? reflection->AddDouble(message, field, number)
                         : reflection->SetDouble(message, field, number);
            }
            break;
        }
        case F::CPPTYPE_INT32: {
            int number = 0;
            ok = absl::SimpleAtoi(value, &number);
            if (ok && repeated) reflection->AddInt32(message, field, number);
            if (ok && !repeated) reflection->SetInt32(message, field, number);
            break;
        }
        case F::CPPTYPE_INT64: {
            long long number = 0;
            ok = absl::SimpleAtoi(value, &number);
            if (ok && repeated) reflection->AddInt64(message, field, number);
            if (ok && !repeated) reflection->SetInt64(message, field, number);
            break;
        }
        case F::CPPTYPE_ENUM: {
            const google::protobuf::EnumValueDescriptor* named =
                field->enum_type()->FindValueByName(value);
            int number = 0;
            if (named == nullptr && absl::SimpleAtoi(value, &number)) {
                named = field->enum_type()->FindValueByNumber(number);
            }
            ok = named != nullptr;
            if (ok && repeated) reflection->AddEnum(message, field, named);
            if (ok && !repeated) reflection->SetEnum(message, field, named);
            break;
        }
        default:
            return absl::InvalidArgumentError(absl::StrCat(path, ": cannot be set from the URL"));
    }
    if (!ok) {
        return absl::InvalidArgumentError(
            absl::StrCat(path, ": '", value, "' is not a valid value"));
    }
    return absl::OkStatus();
}

/// A file a binary or multipart body carries, by its name: the bytes field it fills.
struct FileField {
    const char* name;  ///< the multipart part's name, or file=<name> of a binary body
    const char* path;  ///< singular message fields down to a bytes field
};
constexpr std::array<FileField, 4> kFiles = {{{"cloud", "scan.cloud.data"},
                                              {"left", "scan.stereo.left"},
                                              {"right", "scan.stereo.right"},
                                              {"mesh", "mesh.data"}}};

const FileField* FindFile(std::string_view name) {
    for (const FileField& file : kFiles) {
        if (std::string_view(file.name) == name) return &file;
    }
    return nullptr;
}

/// A file waiting to be bound: files are set after every other field, so that a field given
/// as JSON (`mesh={...}`) cannot clear one.
struct PendingFile {
    const FileField* file;
    std::string bytes;
};

/// Whether the request has the message field a file lies in (RegisterContainer has a scan and
/// a mesh, EstimateVolume a scan).
bool TakesFile(const google::protobuf::Message& message, const FileField& file) {
    const std::string top(file.path, std::strchr(file.path, '.'));
    const google::protobuf::FieldDescriptor* field = message.GetDescriptor()->FindFieldByName(top);
    return field != nullptr && !field->is_repeated() &&
           field->cpp_type() == google::protobuf::FieldDescriptor::CPPTYPE_MESSAGE;
}

/// Sets the bytes field `file` names (TakesFile must hold); given twice is InvalidArgument.
absl::Status SetFileBytes(google::protobuf::Message* message, const FileField& file,
                          std::string bytes) {
    const google::protobuf::FieldDescriptor* field = nullptr;
    for (absl::string_view step : absl::StrSplit(file.path, '.')) {
        if (field != nullptr) message = message->GetReflection()->MutableMessage(message, field);
        field = message->GetDescriptor()->FindFieldByName(std::string(step));
    }
    if (!message->GetReflection()->GetString(*message, field).empty()) {
        return absl::InvalidArgumentError(
            absl::StrCat(file.path, ": given twice (in the request and as a file)"));
    }
    message->GetReflection()->SetString(message, field, std::move(bytes));
    return absl::OkStatus();
}

/// multipart/form-data: a `request` part (the request as JSON), files `cloud`, `left`, `right`
/// and `mesh` (into `files`), any other part naming a field as a query parameter would.
absl::Status BindMultipart(std::string_view content_type, const std::string& body,
                           google::protobuf::Message* message, std::vector<PendingFile>* files) {
    absl::StatusOr<std::string> boundary = MultipartBoundary(content_type);
    if (!boundary.ok()) return boundary.status();
    absl::StatusOr<std::vector<MultipartPart>> parts = ParseMultipart(body, *boundary);
    if (!parts.ok()) return parts.status();
    std::set<std::string_view> seen;
    for (const MultipartPart& part : *parts) {
        if (!seen.insert(part.name).second) {
            return absl::InvalidArgumentError(
                absl::StrCat("multipart body: part '", AbslView(part.name), "' is given twice"));
        }
    }
    for (const MultipartPart& part : *parts) {  // the request first, wherever it is
        if (part.name == "request") {
            SOILVOL_RETURN_IF_ERROR(
                ParseJsonInto(part.data, message, "multipart body: part 'request'"));
        }
    }
    for (const MultipartPart& part : *parts) {
        if (part.name == "request") continue;
        const FileField* file = FindFile(part.name);
        if (file == nullptr) {
            SOILVOL_RETURN_IF_ERROR(
                SetField(message, std::string(part.name), std::string(part.data)));
            continue;
        }
        if (!TakesFile(*message, *file)) {
            const std::string top(file->path, std::strchr(file->path, '.'));
            return absl::InvalidArgumentError(absl::StrCat(
                "multipart body: part '", AbslView(part.name), "': this route takes no ", top));
        }
        files->push_back({file, std::string(part.data)});
    }
    return absl::OkStatus();
}

/// The file a binary body is: the one the query's `file` parameter names (removed from
/// `parameters`), else the cloud.
absl::StatusOr<const FileField*> BinaryBodyFile(
    const google::protobuf::Message& message,
    std::vector<std::pair<std::string, std::string>>& parameters) {
    const FileField* file = &kFiles[0];
    bool named = false;
    for (auto it = parameters.begin(); it != parameters.end();) {
        if (it->first != "file") {
            ++it;
            continue;
        }
        if (named) return absl::InvalidArgumentError("file: is given twice");
        file = FindFile(it->second);
        if (file == nullptr || file == &kFiles[1] || file == &kFiles[2]) {
            return absl::InvalidArgumentError(absl::StrCat(
                "file: '", it->second,
                "' is not cloud or mesh (a stereo pair is two files: send multipart/form-data)"));
        }
        named = true;
        it = parameters.erase(it);
    }
    if (!TakesFile(message, *file)) {
        return absl::InvalidArgumentError(
            named ? absl::StrCat("file: this route takes no ", file->name)
                  : std::string("Content-Type: application/octet-stream is for routes that take "
                                "a scan"));
    }
    return file;
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

BodyKind BodyKindOf(std::string_view content_type) {
    const absl::string_view type =
        absl::StripAsciiWhitespace(AbslView(content_type.substr(0, content_type.find(';'))));
    // A body without a type is JSON, as grpc-gateway's default marshaler reads it.
    if (type.empty() || absl::EqualsIgnoreCase(type, "application/json")) return BodyKind::kJson;
    if (absl::EqualsIgnoreCase(type, "application/octet-stream")) return BodyKind::kBinary;
    if (absl::EqualsIgnoreCase(type, "multipart/form-data")) return BodyKind::kMultipart;
    return BodyKind::kOther;
}

/// The field mask grpc-gateway derives from a PATCH body: the paths of the fields the JSON
/// object sets, through nested objects of message fields (not maps or well-known types).
absl::Status AddMaskPaths(const google::protobuf::Struct& json,
                          const google::protobuf::Descriptor& type, const std::string& prefix,
                          google::protobuf::FieldMask* mask) {
    using F = google::protobuf::FieldDescriptor;
    for (const auto& [key, value] : json.fields()) {
        const F* field = FindField(type, key);
        if (field == nullptr) continue;  // unknown fields are ignored, as the parser does
        const std::string path = prefix + field->name();
        const bool nested = field->cpp_type() == F::CPPTYPE_MESSAGE && !field->is_repeated() &&
                            field->message_type()->file()->package() != "google.protobuf" &&
                            value.kind_case() == google::protobuf::Value::kStructValue;
        if (nested) {
            SOILVOL_RETURN_IF_ERROR(
                AddMaskPaths(value.struct_value(), *field->message_type(), path + ".", mask));
        } else {
            mask->add_paths(path);
        }
    }
    return absl::OkStatus();
}

/// A body naming one field (body: "container"): the JSON goes into that field and, when the
/// request has an empty update_mask, the mask becomes the body's fields (grpc-gateway's rule).
absl::Status BindBodyField(const std::string& body_field, const std::string& body,
                           google::protobuf::Message* message) {
    const google::protobuf::FieldDescriptor* field =
        message->GetDescriptor()->FindFieldByName(body_field);
    if (field == nullptr || field->message_type() == nullptr) {
        return absl::InternalError(absl::StrCat("route body '", body_field, "' is no message"));
    }
    if (body.empty()) return absl::OkStatus();
    google::protobuf::Message* target = message->GetReflection()->MutableMessage(message, field);
    SOILVOL_RETURN_IF_ERROR(ParseJsonInto(body, target, "request body"));
    const google::protobuf::FieldDescriptor* mask_field =
        message->GetDescriptor()->FindFieldByName("update_mask");
    if (mask_field == nullptr ||
        mask_field->message_type() != google::protobuf::FieldMask::descriptor()) {
        return absl::OkStatus();
    }
    google::protobuf::Struct json;
    SOILVOL_RETURN_IF_ERROR(ParseJsonInto(body, &json, "request body"));
    google::protobuf::FieldMask mask;
    SOILVOL_RETURN_IF_ERROR(AddMaskPaths(json, *field->message_type(), "", &mask));
    message->GetReflection()->MutableMessage(message, mask_field)->CopyFrom(mask);
    return absl::OkStatus();
}

absl::Status BindRequest(const HttpRoute& route, const std::map<std::string, std::string>& path,
                         std::string_view query, std::string_view content_type, std::string& body,
                         google::protobuf::Message* message) {
    const BodyKind kind = route.body == "*" ? BodyKindOf(content_type) : BodyKind::kJson;
    absl::StatusOr<std::vector<std::pair<std::string, std::string>>> parameters = ParseQuery(query);
    if (!parameters.ok()) return parameters.status();
    std::vector<PendingFile> files;
    switch (kind) {
        case BodyKind::kJson:
            if (route.body == "*" && !body.empty()) {
                SOILVOL_RETURN_IF_ERROR(ParseJsonInto(body, message, "request body"));
            } else if (!route.body.empty() && route.body != "*") {
                SOILVOL_RETURN_IF_ERROR(BindBodyField(route.body, body, message));
            }
            break;
        case BodyKind::kBinary: {
            SOILVOL_ASSIGN_OR_RETURN(const FileField* file, BinaryBodyFile(*message, *parameters));
            // The file's bytes move into the message: no copy of a large scan.
            files.push_back({file, std::move(body)});
            break;
        }
        case BodyKind::kMultipart:
            SOILVOL_RETURN_IF_ERROR(BindMultipart(content_type, body, message, &files));
            break;
        case BodyKind::kOther:
            return absl::InvalidArgumentError(
                "Content-Type: send application/json, application/octet-stream or "
                "multipart/form-data");
    }
    for (const auto& [field, value] : path) {
        if (absl::Status status = SetField(message, field, value); !status.ok()) return status;
    }
    for (const auto& [name, value] : *parameters) {
        // A JSON body carries every field itself, as grpc-gateway has it for body "*".
        if (route.body == "*" && kind == BodyKind::kJson) {
            return absl::InvalidArgumentError(absl::StrCat("unknown parameter '", name, "'"));
        }
        if (absl::Status status = SetField(message, name, value); !status.ok()) return status;
    }
    for (PendingFile& file : files) {
        SOILVOL_RETURN_IF_ERROR(SetFileBytes(message, *file.file, std::move(file.bytes)));
    }
    return absl::OkStatus();
}

}  // namespace soilvol::server
