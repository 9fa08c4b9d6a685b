#include "server/http/request_binding.hpp"

#include <array>
#include <cstring>
#include <set>
#include <utility>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "core/common/status_macros.hpp"
#include "google/protobuf/field_mask.pb.h"
#include "google/protobuf/struct.pb.h"
#include "server/base/absl_view.hpp"
#include "server/http/field_setter.hpp"
#include "server/http/json_input.hpp"
#include "server/http/multipart.hpp"
#include "server/http/query_string.hpp"

namespace soilvol::server {
namespace {

/// A file a binary or multipart body carries, by its name: the bytes field it fills.
struct FileField {
    const char* name;  ///< the multipart part's name, or file=<name> of a binary body
    const char* path;  ///< singular message fields down to a bytes field
};

constexpr std::array<FileField, 6> kFiles = {{{"cloud", "scan.cloud.data"},
                                              {"left", "scan.stereo.left"},
                                              {"right", "scan.stereo.right"},
                                              {"depth", "scan.depth.depth"},
                                              {"confidence", "scan.depth.confidence"},
                                              {"mesh", "mesh.data"}}};

/// Files that only come with another one (a stereo pair's sides, a depth image's confidence):
/// not a binary body alone.
bool IsCompanionFile(const FileField* file) {
    const std::string_view name = file->name;
    return name == "left" || name == "right" || name == "confidence";
}

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

/// multipart/form-data: a `request` part (the request as JSON), files `cloud`, `left`, `right`,
/// `depth`, `confidence` and `mesh` (into `files`), any other part naming a field as a query
/// parameter would.
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
        if (file == nullptr || IsCompanionFile(file)) {
            return absl::InvalidArgumentError(
                absl::StrCat("file: '", it->second,
                             "' is not cloud, depth or mesh (a stereo pair, or a depth image "
                             "with its confidence, is two files: send multipart/form-data)"));
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

}  // namespace

BodyKind BodyKindOf(std::string_view content_type) {
    const absl::string_view type =
        absl::StripAsciiWhitespace(AbslView(content_type.substr(0, content_type.find(';'))));
    // A body without a type is JSON, as grpc-gateway's default marshaler reads it.
    if (type.empty() || absl::EqualsIgnoreCase(type, "application/json")) return BodyKind::kJson;
    if (absl::EqualsIgnoreCase(type, "application/octet-stream")) return BodyKind::kBinary;
    if (absl::EqualsIgnoreCase(type, "multipart/form-data")) return BodyKind::kMultipart;
    return BodyKind::kOther;
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
