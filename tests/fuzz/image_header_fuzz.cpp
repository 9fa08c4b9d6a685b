// libFuzzer: the image header reader that decides what OpenCV may decode. It must never read
// past the bytes, and any size it reports must be one the header can state.
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "core/stereo/image_header.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string_view bytes(reinterpret_cast<const char*>(data), size);
    const auto header = soilvol::stereo::detail::PeekImageSize(bytes);
    if (header && (header->width < 0 || header->height < 0)) std::abort();
    return 0;
}
