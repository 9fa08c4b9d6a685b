#include "core/io/xyz_writer.hpp"

#include <array>
#include <charconv>

#include "core/io/scalar_type.hpp"

namespace soilvol::io::detail {

void AppendAsciiXyz(const Cloud& points, std::string* out) {
    // Shortest round-trip float is at most 15 characters ("-1.23456789e-38").
    std::array<char, 64> line{};
    for (const Eigen::Vector3f& point : points) {
        char* end = line.data();
        for (int axis = 0; axis < 3; ++axis) {
            end = std::to_chars(end, line.data() + line.size(), point[axis]).ptr;
            *end++ = axis < 2 ? ' ' : '\n';
        }
        out->append(line.data(), end);
    }
}

void AppendBinaryXyz(const Cloud& points, bool big_endian, std::string* out) {
    out->reserve(out->size() + points.size() * 12);
    for (const Eigen::Vector3f& point : points) {
        for (int axis = 0; axis < 3; ++axis) AppendFloat32(point[axis], big_endian, out);
    }
}

}  // namespace soilvol::io::detail
