#include "core/model/model_codec.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <limits>
#include <random>

#include "absl/strings/str_cat.h"
#include "core/sim/scene.hpp"

namespace soilvol::model {
namespace {

const ContainerModel& Model() {
    static const ContainerModel model = [] {
        sim::SceneSpec spec;
        spec.sensor = sim::ViewpointFor(spec.container);
        spec.sensor.range_noise_sigma_m = 0.01;
        const sim::Scene empty = sim::SimulateScene(spec);
        auto built = BuildContainerModel(empty.points, empty.opening_corners_scan, ModelConfig{});
        EXPECT_TRUE(built.ok()) << built.status();
        return *built;
    }();
    return model;
}

uint64_t Fnv1a64(std::string_view bytes) {
    uint64_t hash = 0xcbf29ce484222325ull;
    for (const char c : bytes) {
        hash ^= static_cast<uint8_t>(c);
        hash *= 0x100000001b3ull;
    }
    return hash;
}

// Replaces the payload and fixes size and checksum, as a crafted (not damaged) file would.
std::string Reseal(const std::string& file, std::string payload) {
    std::string out = file.substr(0, 16);
    const uint64_t size = payload.size();
    out.append(reinterpret_cast<const char*>(&size), 8);
    out += payload;
    const uint64_t sum = Fnv1a64(payload);
    out.append(reinterpret_cast<const char*>(&sum), 8);
    return out;
}

std::string Payload(const std::string& file) { return file.substr(24, file.size() - 32); }

TEST(ModelCodecTest, RoundTripKeepsEveryField) {
    const ContainerModel& m = Model();
    const auto decoded = DecodeModel(EncodeModel(m));
    ASSERT_TRUE(decoded.ok()) << decoded.status();
    EXPECT_TRUE(decoded->opening.T_scan_container.isApprox(m.opening.T_scan_container, 0.0));
    EXPECT_EQ(decoded->opening.polygon.Vertices(), m.opening.polygon.Vertices());
    EXPECT_EQ(decoded->opening.area_m2, m.opening.area_m2);
    EXPECT_EQ(decoded->inside, m.inside);
    ASSERT_EQ(decoded->cavity.size(), m.cavity.size());
    for (std::size_t j = 0; j < m.cavity.size(); ++j) {
        EXPECT_EQ(decoded->cavity[j].points, m.cavity[j].points);
        EXPECT_EQ(decoded->cavity[j].weights, m.cavity[j].weights);
        EXPECT_EQ(decoded->cavity[j].sensor, m.cavity[j].sensor);
    }
    EXPECT_EQ(decoded->structure, m.structure);
    EXPECT_EQ(decoded->structure_radius_m, m.structure_radius_m);
    EXPECT_EQ(decoded->smoothing_radius_m, m.smoothing_radius_m);
    EXPECT_EQ(decoded->observed_share, m.observed_share);
    EXPECT_EQ(decoded->alignment_points, m.alignment_points);
    EXPECT_EQ(decoded->alignment_normals, m.alignment_normals);
    EXPECT_EQ(decoded->struck_capacity_m3, m.struck_capacity_m3);
    EXPECT_EQ(decoded->heaped_capacity_iso_m3, m.heaped_capacity_iso_m3);
    EXPECT_EQ(decoded->noise_sigma_m, m.noise_sigma_m);
    EXPECT_EQ(decoded->scan_points, m.scan_points);
    EXPECT_EQ(EncodeModel(*decoded), EncodeModel(m));
}

TEST(ModelCodecTest, RoundTripKeepsWallsMeshAndUnseenSides) {
    ContainerModel m = Model();
    m.walls = {{2, 0.031, 0.003, {{-0.1, 0.02}, {-0.5, 0.08}}, 420}};
    m.mesh = {{{0, 0, 0}, {1, 0, 0}, {0, 1, -0.5}}, {{0, 1, 2}}};
    m.unseen = {{2, 3, 0.12, 0.004}};
    m.struck_capacity_sigma_m3 = 0.0051;
    m.opening.corner_of_vertex = {3, 2, 1, 0};
    const auto decoded = DecodeModel(EncodeModel(m));
    ASSERT_TRUE(decoded.ok()) << decoded.status();
    ASSERT_EQ(decoded->walls.size(), 1u);
    EXPECT_EQ(decoded->walls[0].edge, 2);
    EXPECT_EQ(decoded->walls[0].thickness_sigma_m, 0.003);
    EXPECT_EQ(decoded->walls[0].profile, m.walls[0].profile);
    EXPECT_EQ(decoded->mesh.vertices, m.mesh.vertices);
    EXPECT_EQ(decoded->mesh.triangles, m.mesh.triangles);
    ASSERT_EQ(decoded->unseen.size(), 1u);
    EXPECT_EQ(decoded->unseen[0].from_corner, 2);
    EXPECT_EQ(decoded->unseen[0].sigma_m3, 0.004);
    EXPECT_EQ(decoded->struck_capacity_sigma_m3, 0.0051);
    EXPECT_EQ(decoded->opening.corner_of_vertex, m.opening.corner_of_vertex);
    EXPECT_EQ(EncodeModel(*decoded), EncodeModel(m));
}

TEST(ModelCodecTest, MeshIndexOutOfRangeIsDataLoss) {
    ContainerModel m = Model();
    m.mesh = {{{0, 0, 0}, {1, 0, 0}, {0, 1, -0.5}}, {{0, 1, 3}}};
    const auto decoded = DecodeModel(EncodeModel(m));
    ASSERT_FALSE(decoded.ok());
    EXPECT_EQ(decoded.status().code(), absl::StatusCode::kDataLoss);
    EXPECT_NE(decoded.status().message().find("mesh triangle index"), std::string::npos);
}

TEST(ModelCodecTest, EveryTruncationIsDataLoss) {
    const std::string file = EncodeModel(Model());
    for (std::size_t n = 0; n < file.size(); n += 1 + n / 7) {
        const auto decoded = DecodeModel(std::string_view(file).substr(0, n));
        ASSERT_EQ(decoded.status().code(), absl::StatusCode::kDataLoss) << n;
    }
}

TEST(ModelCodecTest, FlippedBitsFailTheChecksum) {
    const std::string file = EncodeModel(Model());
    std::mt19937_64 rng(7);
    std::uniform_int_distribution<std::size_t> pos(24, file.size() - 1);
    for (int i = 0; i < 200; ++i) {
        std::string damaged = file;
        damaged[pos(rng)] ^= static_cast<char>(1 << (i % 8));
        EXPECT_EQ(DecodeModel(damaged).status().code(), absl::StatusCode::kDataLoss);
    }
}

TEST(ModelCodecTest, OtherVersionIsFailedPrecondition) {
    std::string file = EncodeModel(Model());
    file[8] = static_cast<char>(kModelCodecVersion + 1);
    const auto decoded = DecodeModel(file);
    EXPECT_EQ(decoded.status().code(), absl::StatusCode::kFailedPrecondition);
    EXPECT_NE(decoded.status().message().find(absl::StrCat("version ", kModelCodecVersion + 1)),
              std::string::npos);
}

TEST(ModelCodecTest, GarbageAndForeignBytesAreDataLoss) {
    EXPECT_EQ(DecodeModel("").status().code(), absl::StatusCode::kDataLoss);
    EXPECT_EQ(DecodeModel("ply\nformat ascii 1.0\n").status().code(), absl::StatusCode::kDataLoss);
    std::mt19937_64 rng(3);
    for (int i = 0; i < 100; ++i) {
        std::string junk(1 + rng() % 4096, '\0');
        for (char& c : junk) c = static_cast<char>(rng());
        if (i % 2 == 0) std::memcpy(junk.data(), "SOILVOLM", std::min<std::size_t>(8, junk.size()));
        EXPECT_FALSE(DecodeModel(junk).ok());
    }
}

// Crafted files with a valid checksum must still be checked field by field.
TEST(ModelCodecTest, CraftedContentsAreDataLossNotCrashes) {
    const std::string file = EncodeModel(Model());
    const std::string payload = Payload(file);
    // A huge point count right after the opening.
    const std::size_t inside_at = 16 * 8 + 4 + Model().opening.polygon.Vertices().size() * 16 + 16;
    std::string huge = payload;
    const uint64_t count = std::numeric_limits<uint64_t>::max() / 2;
    std::memcpy(huge.data() + inside_at, &count, 8);
    EXPECT_EQ(DecodeModel(Reseal(file, huge)).status().code(), absl::StatusCode::kDataLoss);
    // A NaN in the pose.
    std::string nan = payload;
    const double q = std::numeric_limits<double>::quiet_NaN();
    std::memcpy(nan.data(), &q, 8);
    EXPECT_EQ(DecodeModel(Reseal(file, nan)).status().code(), absl::StatusCode::kDataLoss);
    // A scaled rotation.
    std::string scaled = payload;
    const double two = 2.0;
    std::memcpy(scaled.data(), &two, 8);
    EXPECT_EQ(DecodeModel(Reseal(file, scaled)).status().code(), absl::StatusCode::kDataLoss);
    // Trailing bytes.
    EXPECT_EQ(DecodeModel(Reseal(file, payload + "x")).status().code(),
              absl::StatusCode::kDataLoss);
    // Random resealed mutations.
    std::mt19937_64 rng(11);
    for (int i = 0; i < 300; ++i) {
        std::string mutated = payload;
        for (int k = 0; k < 4; ++k) mutated[rng() % mutated.size()] = static_cast<char>(rng());
        (void)DecodeModel(Reseal(file, mutated));
    }
}

}  // namespace
}  // namespace soilvol::model
