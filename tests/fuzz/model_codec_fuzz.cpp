// libFuzzer: the stored container model's decoder. The first byte chooses how the rest is read:
// even, as a whole file; odd, as a payload framed with a valid header and checksum, so that the
// fuzzer explores the payload's parser instead of stopping at the checksum. A model it accepts
// must survive a round trip: its encoding decodes to a model with the same encoding (the
// header's reserved word is the one field read and not kept).
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>
#include <string_view>

#include "core/common/checksum.hpp"
#include "core/model/model_codec.hpp"

namespace {

// The header of a valid file: magic, version and reserved word, then the payload size.
std::string Framed(std::string_view payload) {
    static const std::string valid = soilvol::model::EncodeModel(soilvol::model::ContainerModel{});
    constexpr std::size_t kSizeAt = 16, kHeaderBytes = 24;
    std::string out = valid.substr(0, kHeaderBytes);
    const uint64_t size = payload.size();
    std::memcpy(out.data() + kSizeAt, &size, sizeof(size));
    out += payload;
    const uint64_t checksum = soilvol::Fnv1a64(payload);
    out.append(reinterpret_cast<const char*>(&checksum), sizeof(checksum));
    return out;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size == 0) return 0;
    const std::string_view rest(reinterpret_cast<const char*>(data) + 1, size - 1);
    const std::string bytes = (data[0] & 1) != 0 ? Framed(rest) : std::string(rest);
    const auto model = soilvol::model::DecodeModel(bytes);
    if (!model.ok()) return 0;
    const std::string once = soilvol::model::EncodeModel(*model);
    const auto again = soilvol::model::DecodeModel(once);
    if (!again.ok() || soilvol::model::EncodeModel(*again) != once) std::abort();
    return 0;
}
