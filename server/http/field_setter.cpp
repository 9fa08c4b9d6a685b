#include "server/http/field_setter.hpp"

#include "absl/status/statusor.h"
#include "absl/strings/escaping.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "server/base/absl_view.hpp"
#include "server/http/json_input.hpp"

namespace soilvol::server {
namespace {

using F = google::protobuf::FieldDescriptor;

/// The field a dotted name ends at, `message` moved to the message that holds it, and the
/// field's proto path ("sensor_pose.translation") in `path`.
absl::StatusOr<const F*> ResolveField(google::protobuf::Message*& message, const std::string& name,
                                      std::string& path) {
    const F* field = nullptr;
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
    return field;
}

/// A message field from its proto3 JSON. FieldMask, Timestamp and Duration are JSON strings;
/// a query gives them bare (?update_mask=displayName,labels), as grpc-gateway takes them.
absl::Status SetMessageField(google::protobuf::Message* message, const F* field,
                             const std::string& path, const std::string& value) {
    const google::protobuf::Reflection* reflection = message->GetReflection();
    google::protobuf::Message* target = field->is_repeated()
                                            ? reflection->AddMessage(message, field)
                                            : reflection->MutableMessage(message, field);
    const std::string& type = field->message_type()->full_name();
    const bool string_form = type == "google.protobuf.FieldMask" ||
                             type == "google.protobuf.Timestamp" ||
                             type == "google.protobuf.Duration";
    if (string_form && (value.empty() || value.front() != '"')) {
        return ParseJsonInto(absl::StrCat("\"", absl::CEscape(value), "\""), target, path);
    }
    return ParseJsonInto(value, target, path);
}

absl::Status SetStringField(google::protobuf::Message* message, const F* field,
                            const std::string& path, const std::string& value) {
    const google::protobuf::Reflection* reflection = message->GetReflection();
    if (field->type() == F::TYPE_BYTES) {
        return absl::InvalidArgumentError(absl::StrCat(path, ": bytes cannot be set from the URL"));
    }
    if (field->is_repeated()) {
        reflection->AddString(message, field, value);
        return absl::OkStatus();
    }
    if (reflection->HasField(*message, field) && reflection->GetString(*message, field) != value) {
        return absl::InvalidArgumentError(absl::StrCat(path, ": the body says '",
                                                       reflection->GetString(*message, field),
                                                       "' but the URL says '", value, "'"));
    }
    reflection->SetString(message, field, value);
    return absl::OkStatus();
}

const google::protobuf::EnumValueDescriptor* EnumValueOf(const F* field, const std::string& value) {
    const google::protobuf::EnumValueDescriptor* named = field->enum_type()->FindValueByName(value);
    int number = 0;
    if (named == nullptr && absl::SimpleAtoi(value, &number)) {
        named = field->enum_type()->FindValueByNumber(number);
    }
    return named;
}

/// A bool, number or enum from its text; false when the text is no such value.
bool SetScalarField(google::protobuf::Message* message, const F* field, const std::string& value) {
    const google::protobuf::Reflection* r = message->GetReflection();
    const bool repeated = field->is_repeated();
    double real = 0.0;
    int int32 = 0;
    long long int64 = 0;
    switch (field->cpp_type()) {
        case F::CPPTYPE_BOOL:
            if (value != "true" && value != "false") return false;
            repeated ? r->AddBool(message, field, value == "true")
                     : r->SetBool(message, field, value == "true");
            return true;
        case F::CPPTYPE_DOUBLE:
            if (!absl::SimpleAtod(value, &real)) return false;
            repeated ? r->AddDouble(message, field, real) : r->SetDouble(message, field, real);
            return true;
        case F::CPPTYPE_FLOAT:
            if (!absl::SimpleAtod(value, &real)) return false;
            repeated ? r->AddFloat(message, field, static_cast<float>(real))
                     : r->SetFloat(message, field, static_cast<float>(real));
            return true;
        case F::CPPTYPE_INT32:
            if (!absl::SimpleAtoi(value, &int32)) return false;
            repeated ? r->AddInt32(message, field, int32) : r->SetInt32(message, field, int32);
            return true;
        case F::CPPTYPE_INT64:
            if (!absl::SimpleAtoi(value, &int64)) return false;
            repeated ? r->AddInt64(message, field, int64) : r->SetInt64(message, field, int64);
            return true;
        case F::CPPTYPE_ENUM:
            if (EnumValueOf(field, value) == nullptr) return false;
            repeated ? r->AddEnum(message, field, EnumValueOf(field, value))
                     : r->SetEnum(message, field, EnumValueOf(field, value));
            return true;
        case F::CPPTYPE_UINT32:
        case F::CPPTYPE_UINT64:
        case F::CPPTYPE_STRING:
        case F::CPPTYPE_MESSAGE:
            return false;  // no unsigned fields in the API; strings and messages: above
    }
    return false;
}

}  // namespace

const google::protobuf::FieldDescriptor* FindField(const google::protobuf::Descriptor& type,
                                                   const std::string& name) {
    const google::protobuf::FieldDescriptor* field = type.FindFieldByName(name);
    return field != nullptr ? field : type.FindFieldByCamelcaseName(name);
}

absl::Status SetField(google::protobuf::Message* message, const std::string& name,
                      const std::string& value) {
    std::string path;
    absl::StatusOr<const F*> field = ResolveField(message, name, path);
    if (!field.ok()) return field.status();
    switch ((*field)->cpp_type()) {
        case F::CPPTYPE_MESSAGE:
            return SetMessageField(message, *field, path, value);
        case F::CPPTYPE_STRING:
            return SetStringField(message, *field, path, value);
        case F::CPPTYPE_UINT32:
        case F::CPPTYPE_UINT64:
            return absl::InvalidArgumentError(absl::StrCat(path, ": cannot be set from the URL"));
        case F::CPPTYPE_BOOL:
        case F::CPPTYPE_DOUBLE:
        case F::CPPTYPE_FLOAT:
        case F::CPPTYPE_INT32:
        case F::CPPTYPE_INT64:
        case F::CPPTYPE_ENUM:
            break;
    }
    if (!SetScalarField(message, *field, value)) {
        return absl::InvalidArgumentError(
            absl::StrCat(path, ": '", value, "' is not a valid value"));
    }
    return absl::OkStatus();
}

}  // namespace soilvol::server
