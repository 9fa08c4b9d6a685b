#pragma once

// Private to core/stereo: image sizes read from file headers, before anything is decoded.

#include <cstdint>
#include <optional>
#include <string_view>

namespace soilvol::stereo::detail {

/// Width and height [px] as a header declares them (not validated: may be 0 or huge).
struct HeaderSize {
    std::int64_t width = 0;
    std::int64_t height = 0;
};

/// The size declared by a PNG, JPEG, BMP, PNM (P1-P6) or TIFF header, never negative; nullopt
/// for other formats or a header too short or malformed to tell.
std::optional<HeaderSize> PeekImageSize(std::string_view bytes);

}  // namespace soilvol::stereo::detail
