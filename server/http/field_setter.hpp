#pragma once

#include <string>

#include "absl/status/status.h"
#include "google/protobuf/descriptor.h"
#include "google/protobuf/message.h"

namespace soilvol::server {

/// The field of `type` called `name` by its proto name or its JSON (lowerCamel) name.
const google::protobuf::FieldDescriptor* FindField(const google::protobuf::Descriptor& type,
                                                   const std::string& name);

/// Sets the field a path value or query parameter names (grpc-gateway's rules: a dotted path
/// of singular message fields to a scalar or enum, repeated scalars appended), or - where a
/// query cannot express it - a message field from its proto3 JSON. A string the body already
/// set to another value is InvalidArgument (the body and the URL disagree); bytes cannot be
/// set from a URL. InvalidArgument naming the parameter or the field's path.
absl::Status SetField(google::protobuf::Message* message, const std::string& name,
                      const std::string& value);

}  // namespace soilvol::server
