// Writes the seed inputs that come from soilvol's own encoders into <dir>/<target>/: a stored
// model, PCD/PLY clouds in every encoding and a cube mesh in every mesh format (the stored
// calibration record's seed is committed).
// scripts/fuzz.sh adds them to the committed hand-made seeds in tests/fuzz/corpus/ before each run.
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "core/io/cloud_codec.hpp"
#include "core/io/mesh_codec.hpp"
#include "core/model/model_codec.hpp"

namespace {

namespace fs = std::filesystem;
using soilvol::Cloud;

void Write(const fs::path& dir, const std::string& name, const std::string& bytes) {
    fs::create_directories(dir);
    std::ofstream(dir / name, std::ios::binary) << bytes;
}

Cloud Points(int n, float z) {
    Cloud points;
    for (int i = 0; i < n; ++i) {
        points.emplace_back(0.1f * static_cast<float>(i % 5), 0.1f * static_cast<float>(i / 5),
                            z + 0.01f * static_cast<float>(i % 3));
    }
    return points;
}

// A small model with every field set (not a fit: the decoder's input, not the estimator's).
soilvol::model::ContainerModel SmallModel() {
    soilvol::model::ContainerModel model;
    model.opening.polygon =
        soilvol::Polygon2d({{-0.5, -0.3}, {0.5, -0.3}, {0.5, 0.3}, {-0.5, 0.3}});
    model.opening.area_m2 = 0.6;
    model.inside = Points(10, -0.4f);
    model.structure = Points(6, 0.1f);
    model.alignment_points = Points(8, 0.05f);
    model.alignment_normals = Cloud(8, Eigen::Vector3f::UnitZ());
    soilvol::WeightedCloud cavity;
    cavity.points = Points(10, -0.4f);
    cavity.weights.assign(10, 1.0f);
    cavity.sensor = Eigen::Vector3d(0.0, -1.0, 2.0);
    model.cavity.push_back(cavity);
    model.structure_radius_m = 0.05;
    model.smoothing_radius_m = 0.08;
    model.depth_m = 0.4;
    model.struck_capacity_m3 = 0.24;
    model.heaped_capacity_sae_m3 = 0.3;
    model.heaped_capacity_iso_m3 = 0.27;
    model.noise_sigma_m = 0.01;
    model.observed_share = 0.9;
    model.scan_points = 30;
    model.outside_points = 8;
    return model;
}

// The unit cube: 8 corners, 12 triangles counter-clockwise seen from outside.
soilvol::io::DecodedMesh Cube() {
    soilvol::io::DecodedMesh cube;
    for (int i = 0; i < 8; ++i) {
        cube.vertices.emplace_back((i + 1) / 2 % 2, i / 2 % 2, i / 4);
    }
    cube.triangles = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7}, {0, 1, 5}, {0, 5, 4},
                      {3, 7, 6}, {3, 6, 2}, {0, 4, 7}, {0, 7, 3}, {1, 2, 6}, {1, 6, 5}};
    return cube;
}

std::string Xyz(const Eigen::Vector3d& v) {
    return std::to_string(v.x()) + " " + std::to_string(v.y()) + " " + std::to_string(v.z());
}

// OBJ: 1-based indices for half the faces, negative relative ones and v/vt/vn for the rest.
std::string CubeObj(const soilvol::io::DecodedMesh& cube) {
    std::string out = "# cube\no cube\n";
    for (const Eigen::Vector3d& v : cube.vertices) out += "v " + Xyz(v) + "\n";
    out += "vt 0 0\nvn 0 0 1\n";
    for (std::size_t i = 0; i < cube.triangles.size(); ++i) {
        out += "f";
        for (int k = 0; k < 3; ++k) {
            const int index = cube.triangles[i][k];
            out += i % 2 == 0 ? " " + std::to_string(index + 1)
                              : " " + std::to_string(index - 8) + "/1/1";
        }
        out += "\n";
    }
    return out;
}

template <typename T>
void AppendBytes(T value, bool big_endian, std::string* out) {
    char bytes[sizeof(T)];
    std::memcpy(bytes, &value, sizeof(T));
    for (std::size_t i = 0; i < sizeof(T); ++i) {
        out->push_back(bytes[big_endian ? sizeof(T) - 1 - i : i]);
    }
}

const char* PlyFormatName(soilvol::io::PlyEncoding encoding) {
    switch (encoding) {
        case soilvol::io::PlyEncoding::kAscii:
            return "ascii";
        case soilvol::io::PlyEncoding::kBinaryLittleEndian:
            return "binary_little_endian";
        case soilvol::io::PlyEncoding::kBinaryBigEndian:
            return "binary_big_endian";
    }
    return "ascii";
}

// PLY with a uchar-counted int face list, in the given encoding.
std::string CubePly(const soilvol::io::DecodedMesh& cube, soilvol::io::PlyEncoding encoding) {
    using soilvol::io::PlyEncoding;
    const bool ascii = encoding == PlyEncoding::kAscii;
    const bool big = encoding == PlyEncoding::kBinaryBigEndian;
    std::string out = std::string("ply\nformat ") + PlyFormatName(encoding) +
                      " 1.0\nelement vertex 8\nproperty float x\nproperty float y\n"
                      "property float z\nelement face 12\n"
                      "property list uchar int vertex_indices\nend_header\n";
    for (const Eigen::Vector3d& v : cube.vertices) {
        if (ascii) out += Xyz(v) + "\n";
        for (int axis = 0; axis < 3 && !ascii; ++axis) {
            AppendBytes(static_cast<float>(v[axis]), big, &out);
        }
    }
    for (const Eigen::Vector3i& t : cube.triangles) {
        if (ascii) {
            out += "3 " + std::to_string(t[0]) + " " + std::to_string(t[1]) + " " +
                   std::to_string(t[2]) + "\n";
            continue;
        }
        AppendBytes(std::uint8_t{3}, big, &out);
        for (int k = 0; k < 3; ++k) AppendBytes(std::int32_t{t[k]}, big, &out);
    }
    return out;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 2) {
        std::fprintf(stderr, "usage: %s <corpus-dir>\n", argv[0]);
        return 2;
    }
    const fs::path root(argv[1]);
    using soilvol::io::PcdEncoding;
    using soilvol::io::PlyEncoding;
    const Cloud cloud = Points(12, 1.5f);
    // The cloud target reads its first byte as the raw-xyz switch.
    Write(root / "fuzz_cloud_decoder", "ply_binary",
          std::string(1, '\0') + soilvol::io::EncodePly(cloud));
    Write(root / "fuzz_cloud_decoder", "ply_ascii",
          std::string(1, '\0') + soilvol::io::EncodePly(cloud, PlyEncoding::kAscii));
    Write(root / "fuzz_cloud_decoder", "ply_big_endian",
          std::string(1, '\0') + soilvol::io::EncodePly(cloud, PlyEncoding::kBinaryBigEndian));
    Write(root / "fuzz_cloud_decoder", "pcd_binary",
          std::string(1, '\0') + soilvol::io::EncodePcd(cloud));
    soilvol::Pose sensor = soilvol::Pose::Identity();
    sensor.translation() = Eigen::Vector3d(3.0, -2.0, 5.0);
    sensor.linear() = Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitX()).matrix();
    Write(root / "fuzz_cloud_decoder", "pcd_viewpoint",
          std::string(1, '\0') + soilvol::io::EncodePcd(cloud, PcdEncoding::kAscii, sensor));
    Write(root / "fuzz_cloud_decoder", "pcd_ascii",
          std::string(1, '\0') + soilvol::io::EncodePcd(cloud, PcdEncoding::kAscii));
    Write(root / "fuzz_cloud_decoder", "pcd_compressed",
          std::string(1, '\0') + soilvol::io::EncodePcd(cloud, PcdEncoding::kBinaryCompressed));
    Write(root / "fuzz_cloud_decoder", "raw",
          std::string(1, '\x01') + soilvol::io::EncodeRawXyzF32(cloud));
    // The unit cube in every mesh format.
    const soilvol::io::DecodedMesh cube = Cube();
    const fs::path meshes = root / "fuzz_mesh_decoder";
    Write(meshes, "cube_binary.stl", soilvol::io::EncodeStl(cube));
    Write(meshes, "cube_ascii.stl", soilvol::io::EncodeStl(cube, /*binary=*/false));
    Write(meshes, "cube.obj", CubeObj(cube));
    Write(meshes, "cube_ascii.ply", CubePly(cube, PlyEncoding::kAscii));
    Write(meshes, "cube_little_endian.ply", CubePly(cube, PlyEncoding::kBinaryLittleEndian));
    Write(meshes, "cube_big_endian.ply", CubePly(cube, PlyEncoding::kBinaryBigEndian));
    // The model target reads its first byte as a switch: even, a whole file; odd, a payload it
    // frames (here: the payload of the same model).
    const std::string model = soilvol::model::EncodeModel(SmallModel());
    Write(root / "fuzz_model_codec", "file", std::string(1, '\0') + model);
    Write(root / "fuzz_model_codec", "payload",
          std::string(1, '\x01') + model.substr(24, model.size() - 24 - 8));
    // Images in each format whose header is read, grey and colour, 8 and 16 bits.
    cv::Mat grey(8, 8, CV_8UC1);
    for (int i = 0; i < 64; ++i) grey.at<uchar>(i / 8, i % 8) = static_cast<uchar>(4 * i);
    cv::Mat colour, deep;
    cv::merge(std::vector<cv::Mat>{grey, grey, grey}, colour);
    grey.convertTo(deep, CV_16UC1, 256.0);
    const struct {
        const char* name;
        const cv::Mat& image;
        std::vector<int> flags;
    } images[] = {{".png", grey, {}},   {".png", deep, {}},
                  {".jpg", colour, {}}, {".jpg", grey, {cv::IMWRITE_JPEG_PROGRESSIVE, 1}},
                  {".bmp", colour, {}}, {".pgm", grey, {}},
                  {".ppm", colour, {}}, {".tif", deep, {}}};
    int index = 0;
    for (const auto& image : images) {
        std::vector<uchar> bytes;
        if (!cv::imencode(image.name, image.image, bytes, image.flags)) continue;
        Write(root / "fuzz_image_header", "image" + std::to_string(index++) + image.name,
              std::string(bytes.begin(), bytes.end()));
    }
    return 0;
}
