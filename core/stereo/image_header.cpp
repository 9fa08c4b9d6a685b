#include "core/stereo/image_header.hpp"

#include <cstddef>

namespace soilvol::stereo::detail {
namespace {

// Reads an unsigned integer of `size` bytes at `offset`; false when out of range.
bool ReadUnsigned(std::string_view bytes, std::size_t offset, int size, bool big_endian,
                  std::uint32_t* value) {
    if (offset > bytes.size() || bytes.size() - offset < static_cast<std::size_t>(size)) {
        return false;
    }
    *value = 0;
    for (int i = 0; i < size; ++i) {
        const int index = big_endian ? i : size - 1 - i;
        *value = (*value << 8) | static_cast<unsigned char>(bytes[offset + index]);
    }
    return true;
}

std::optional<HeaderSize> PngSize(std::string_view bytes) {
    std::uint32_t width = 0;
    std::uint32_t height = 0;
    if (bytes.size() < 24 || bytes.substr(12, 4) != "IHDR" ||
        !ReadUnsigned(bytes, 16, 4, true, &width) || !ReadUnsigned(bytes, 20, 4, true, &height)) {
        return std::nullopt;
    }
    return HeaderSize{width, height};
}

// ITU T.81 B.1.1: marker segments up to the first frame header (SOFn).
std::optional<HeaderSize> JpegSize(std::string_view bytes) {
    std::size_t pos = 2;
    std::uint32_t byte = 0;
    while (ReadUnsigned(bytes, pos, 1, true, &byte) && byte == 0xFF) {
        std::uint32_t marker = 0;
        if (!ReadUnsigned(bytes, pos + 1, 1, true, &marker)) return std::nullopt;
        if (marker == 0xFF) {  // fill byte
            ++pos;
            continue;
        }
        pos += 2;
        if (marker == 0x01 || (marker >= 0xD0 && marker <= 0xD7)) continue;  // no payload
        if (marker == 0xD9 || marker == 0xDA) return std::nullopt;           // EOI or SOS: no frame
        const bool frame =
            marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
        std::uint32_t length = 0;
        std::uint32_t height = 0;
        std::uint32_t width = 0;
        if (!ReadUnsigned(bytes, pos, 2, true, &length) || length < 2) return std::nullopt;
        if (frame) {
            if (!ReadUnsigned(bytes, pos + 3, 2, true, &height) ||
                !ReadUnsigned(bytes, pos + 5, 2, true, &width)) {
                return std::nullopt;
            }
            return HeaderSize{width, height};
        }
        pos += length;
    }
    return std::nullopt;
}

std::optional<HeaderSize> BmpSize(std::string_view bytes) {
    std::uint32_t header_size = 0;
    std::uint32_t width = 0;
    std::uint32_t height = 0;
    if (!ReadUnsigned(bytes, 14, 4, false, &header_size)) return std::nullopt;
    if (header_size == 12) {  // OS/2 BITMAPCOREHEADER: 16-bit sizes
        if (!ReadUnsigned(bytes, 18, 2, false, &width) ||
            !ReadUnsigned(bytes, 20, 2, false, &height)) {
            return std::nullopt;
        }
        return HeaderSize{width, height};
    }
    if (!ReadUnsigned(bytes, 18, 4, false, &width) || !ReadUnsigned(bytes, 22, 4, false, &height)) {
        return std::nullopt;
    }
    // Signed 32-bit; a negative height means top-down rows.
    const auto as_signed = [](std::uint32_t v) {
        return v >= 0x80000000u ? static_cast<std::int64_t>(v) - 0x100000000LL
                                : static_cast<std::int64_t>(v);
    };
    const std::int64_t signed_height = as_signed(height);
    // A negative width is no bitmap (only heights carry the row order).
    if (as_signed(width) < 0) return std::nullopt;
    return HeaderSize{as_signed(width), signed_height < 0 ? -signed_height : signed_height};
}

// Netpbm: "P<n>", then width and height as decimal text between whitespace and # comments.
std::optional<HeaderSize> PnmSize(std::string_view bytes) {
    std::size_t pos = 2;
    std::int64_t values[2] = {0, 0};
    for (std::int64_t& value : values) {
        while (pos < bytes.size()) {
            const char c = bytes[pos];
            if (c == '#') {
                while (pos < bytes.size() && bytes[pos] != '\n' && bytes[pos] != '\r') ++pos;
            } else if (c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f') {
                ++pos;
            } else {
                break;
            }
        }
        const std::size_t start = pos;
        while (pos < bytes.size() && bytes[pos] >= '0' && bytes[pos] <= '9' && pos - start < 12) {
            value = value * 10 + (bytes[pos] - '0');
            ++pos;
        }
        if (pos == start) return std::nullopt;
    }
    return HeaderSize{values[0], values[1]};
}

// TIFF 6.0 sec. 2: the first IFD's ImageWidth (256) and ImageLength (257) entries.
std::optional<HeaderSize> TiffSize(std::string_view bytes, bool big_endian) {
    std::uint32_t ifd = 0;
    std::uint32_t count = 0;
    if (!ReadUnsigned(bytes, 4, 4, big_endian, &ifd) ||
        !ReadUnsigned(bytes, ifd, 2, big_endian, &count)) {
        return std::nullopt;
    }
    HeaderSize size{-1, -1};
    for (std::uint32_t i = 0; i < count; ++i) {
        const std::size_t entry =
            static_cast<std::size_t>(ifd) + 2 + 12 * static_cast<std::size_t>(i);
        std::uint32_t tag = 0;
        std::uint32_t type = 0;
        std::uint32_t value = 0;
        if (!ReadUnsigned(bytes, entry, 2, big_endian, &tag) ||
            !ReadUnsigned(bytes, entry + 2, 2, big_endian, &type)) {
            return std::nullopt;
        }
        if (tag != 256 && tag != 257) continue;
        if (type != 3 && type != 4) return std::nullopt;  // SHORT or LONG only
        if (!ReadUnsigned(bytes, entry + 8, type == 3 ? 2 : 4, big_endian, &value)) {
            return std::nullopt;
        }
        (tag == 256 ? size.width : size.height) = value;
    }
    if (size.width < 0 || size.height < 0) return std::nullopt;
    return size;
}

}  // namespace

std::optional<HeaderSize> PeekImageSize(std::string_view bytes) {
    if (bytes.substr(0, 8) == std::string_view("\x89PNG\r\n\x1a\n", 8)) return PngSize(bytes);
    if (bytes.substr(0, 2) == "\xFF\xD8") return JpegSize(bytes);
    if (bytes.substr(0, 2) == "BM") return BmpSize(bytes);
    if (bytes.size() >= 2 && bytes[0] == 'P' && bytes[1] >= '1' && bytes[1] <= '6') {
        return PnmSize(bytes);
    }
    if (bytes.substr(0, 4) == std::string_view("II*\0", 4)) return TiffSize(bytes, false);
    if (bytes.substr(0, 4) == std::string_view("MM\0*", 4)) return TiffSize(bytes, true);
    return std::nullopt;
}

}  // namespace soilvol::stereo::detail
