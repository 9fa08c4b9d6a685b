// libFuzzer: the cloud decoders (PLY, PCD incl. binary_compressed, raw xyz) on any bytes. The
// first byte chooses whether raw xyz is accepted; a decoded cloud must hold finite points only.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "core/io/cloud_codec.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size == 0) return 0;
    const bool allow_raw = (data[0] & 1) != 0;
    const std::string_view bytes(reinterpret_cast<const char*>(data) + 1, size - 1);
    const auto cloud = soilvol::io::DecodeCloud(bytes, allow_raw);
    if (!cloud.ok()) return 0;
    if (cloud->points.empty()) std::abort();
    for (const auto& p : cloud->points) {
        if (!p.allFinite()) std::abort();
    }
    return 0;
}
