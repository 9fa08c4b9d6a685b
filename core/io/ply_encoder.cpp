#include "absl/strings/str_cat.h"
#include "core/io/cloud_codec.hpp"
#include "core/io/xyz_writer.hpp"

namespace soilvol::io {
namespace {

const char* FormatName(PlyEncoding encoding) {
    switch (encoding) {
        case PlyEncoding::kAscii:
            return "ascii";
        case PlyEncoding::kBinaryLittleEndian:
            return "binary_little_endian";
        case PlyEncoding::kBinaryBigEndian:
            return "binary_big_endian";
    }
    return "binary_little_endian";
}

}  // namespace

std::string EncodePly(const Cloud& points, PlyEncoding encoding) {
    std::string out = absl::StrCat("ply\nformat ", FormatName(encoding),
                                   " 1.0\ncomment soilvol\nelement vertex ", points.size(),
                                   "\nproperty float x\nproperty float y\nproperty float z\n"
                                   "end_header\n");
    if (encoding == PlyEncoding::kAscii) {
        detail::AppendAsciiXyz(points, &out);
    } else {
        detail::AppendBinaryXyz(points, encoding == PlyEncoding::kBinaryBigEndian, &out);
    }
    return out;
}

}  // namespace soilvol::io
