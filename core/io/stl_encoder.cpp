#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <charconv>
#include <cstdint>
#include <limits>
#include <vector>

#include "core/io/mesh_codec.hpp"
#include "core/io/scalar_type.hpp"

namespace soilvol::io {
namespace {

using Corners = std::array<Eigen::Vector3f, 3>;

// Corners of every triangle whose indices are in range, as float32.
std::vector<Corners> TriangleCorners(const DecodedMesh& mesh) {
    const auto narrow = [&mesh](int index) {
        const Eigen::Vector3d& v = mesh.vertices[static_cast<std::size_t>(index)];
        return Eigen::Vector3f(detail::NarrowToFloat(v.x()), detail::NarrowToFloat(v.y()),
                               detail::NarrowToFloat(v.z()));
    };
    const int count = static_cast<int>(
        std::min<std::size_t>(mesh.vertices.size(), std::numeric_limits<int>::max()));
    std::vector<Corners> corners;
    corners.reserve(mesh.triangles.size());
    for (const Eigen::Vector3i& t : mesh.triangles) {
        if (t.minCoeff() < 0 || t.maxCoeff() >= count) continue;
        corners.push_back({narrow(t[0]), narrow(t[1]), narrow(t[2])});
    }
    return corners;
}

// Unit normal by the right-hand rule over the corner order (in double: float corners cannot
// overflow it); zero for a degenerate triangle.
Eigen::Vector3f Normal(const Corners& c) {
    const Eigen::Vector3d a = c[0].cast<double>();
    const Eigen::Vector3d n = (c[1].cast<double>() - a).cross(c[2].cast<double>() - a);
    const double length = n.norm();
    return length > 0.0 ? Eigen::Vector3f((n / length).cast<float>()) : Eigen::Vector3f::Zero();
}

// "<prefix> x y z\n", each float in its shortest exact decimal form.
void AppendAsciiXyz(std::string_view prefix, const Eigen::Vector3f& xyz, std::string* out) {
    std::array<char, 64> text{};
    char* end = text.data();
    for (int axis = 0; axis < 3; ++axis) {
        *end++ = ' ';
        end = std::to_chars(end, text.data() + text.size(), xyz[axis]).ptr;
    }
    out->append(prefix).append(text.data(), end).push_back('\n');
}

void AppendBinaryXyz(const Eigen::Vector3f& xyz, std::string* out) {
    for (int axis = 0; axis < 3; ++axis)
        detail::AppendFloat32(xyz[axis], /*big_endian=*/false, out);
}

}  // namespace

std::string EncodeStl(const DecodedMesh& mesh, bool binary) {
    const std::vector<Corners> triangles = TriangleCorners(mesh);
    std::string out;
    if (!binary) {
        out = "solid soilvol\n";
        for (const Corners& corners : triangles) {
            AppendAsciiXyz("  facet normal", Normal(corners), &out);
            out += "    outer loop\n";
            for (const Eigen::Vector3f& corner : corners) {
                AppendAsciiXyz("      vertex", corner, &out);
            }
            out += "    endloop\n  endfacet\n";
        }
        out += "endsolid soilvol\n";
        return out;
    }
    // Header padded with zero bytes (not "solid", which readers take for ASCII), then the count.
    out = "soilvol binary STL";
    out.resize(80, '\0');
    detail::AppendUint32Le(static_cast<std::uint32_t>(triangles.size()), &out);
    out.reserve(out.size() + 50 * triangles.size());
    for (const Corners& corners : triangles) {
        AppendBinaryXyz(Normal(corners), &out);
        for (const Eigen::Vector3f& corner : corners) AppendBinaryXyz(corner, &out);
        out.append(2, '\0');  // attribute byte count
    }
    return out;
}

}  // namespace soilvol::io
