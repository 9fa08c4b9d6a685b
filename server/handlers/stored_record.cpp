#include "server/handlers/stored_record.hpp"

#include <cstdint>

#include "absl/strings/str_cat.h"

namespace soilvol::server {

std::string EncodeStoredRecord(const google::protobuf::Message& info, std::string_view body) {
    const std::string bytes = info.SerializeAsString();
    const auto size = static_cast<uint32_t>(bytes.size());
    std::string out;
    out.reserve(4 + bytes.size() + body.size());
    for (int i = 0; i < 4; ++i) out.push_back(static_cast<char>((size >> (8 * i)) & 0xffu));
    out += bytes;
    out += body;
    return out;
}

absl::Status DecodeStoredRecord(std::string_view payload, google::protobuf::Message* info,
                                std::string_view* body) {
    if (payload.size() < 4) return absl::DataLossError("record shorter than its header");
    uint32_t size = 0;
    for (int i = 0; i < 4; ++i) {
        size |= static_cast<uint32_t>(static_cast<unsigned char>(payload[i])) << (8 * i);
    }
    if (size > payload.size() - 4) {
        return absl::DataLossError(absl::StrCat("record header claims ", size,
                                                " bytes of description; ", payload.size() - 4,
                                                " remain"));
    }
    if (!info->ParseFromArray(payload.data() + 4, static_cast<int>(size))) {
        return absl::DataLossError("record description does not parse");
    }
    *body = payload.substr(4 + size);
    return absl::OkStatus();
}

}  // namespace soilvol::server
