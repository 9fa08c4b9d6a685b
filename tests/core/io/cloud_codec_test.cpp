#include "core/io/cloud_codec.hpp"

#include <gtest/gtest.h>

#include <functional>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "tests/core/io/codec_test_util.hpp"

namespace soilvol::io {
namespace {

using test::IsInvalidWith;
using test::RandomCloud;
using test::SameBits;

constexpr float kNan = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();

struct Codec {
    std::string name;
    std::function<std::string(const Cloud&)> encode;
    CloudFormat format;
};

std::vector<Codec> AllCodecs() {
    return {
        {"PlyAscii", [](const Cloud& c) { return EncodePly(c, PlyEncoding::kAscii); },
         CloudFormat::kPly},
        {"PlyLittleEndian",
         [](const Cloud& c) { return EncodePly(c, PlyEncoding::kBinaryLittleEndian); },
         CloudFormat::kPly},
        {"PlyBigEndian", [](const Cloud& c) { return EncodePly(c, PlyEncoding::kBinaryBigEndian); },
         CloudFormat::kPly},
        {"PcdAscii", [](const Cloud& c) { return EncodePcd(c, PcdEncoding::kAscii); },
         CloudFormat::kPcd},
        {"PcdBinary", [](const Cloud& c) { return EncodePcd(c, PcdEncoding::kBinary); },
         CloudFormat::kPcd},
        {"PcdCompressed",
         [](const Cloud& c) { return EncodePcd(c, PcdEncoding::kBinaryCompressed); },
         CloudFormat::kPcd},
        {"Raw", [](const Cloud& c) { return EncodeRawXyzF32(c); }, CloudFormat::kRawXyzF32},
    };
}

// Hard cases for exact text round trips: extremes, subnormals, signed zero.
Cloud TrickyCloud() {
    constexpr float kMax = std::numeric_limits<float>::max();
    constexpr float kMinNormal = std::numeric_limits<float>::min();
    constexpr float kSubnormal = std::numeric_limits<float>::denorm_min();
    Cloud cloud = RandomCloud(200, 7);
    cloud.push_back({kMax, -kMax, 0.0f});
    cloud.push_back({kMinNormal, kSubnormal, -0.0f});
    cloud.push_back({0.1f, 1.0f / 3.0f, -123456.789f});
    return cloud;
}

class CodecTest : public ::testing::TestWithParam<Codec> {};

TEST_P(CodecTest, RandomCloudRoundTripsExactly) {
    const Cloud cloud = TrickyCloud();
    const auto decoded = DecodeCloud(GetParam().encode(cloud), /*allow_raw=*/true);
    ASSERT_TRUE(decoded.ok()) << decoded.status();
    EXPECT_TRUE(SameBits(decoded->points, cloud));
    EXPECT_EQ(decoded->dropped_nonfinite, 0u);
    EXPECT_EQ(decoded->format, GetParam().format);
}

TEST_P(CodecTest, SinglePointRoundTrips) {
    const Cloud cloud = {{1.5f, -2.25f, 3.0f}};
    const auto decoded = DecodeCloud(GetParam().encode(cloud), /*allow_raw=*/true);
    ASSERT_TRUE(decoded.ok()) << decoded.status();
    EXPECT_TRUE(SameBits(decoded->points, cloud));
}

TEST_P(CodecTest, MixedNonFinitePointsAreDroppedAndCounted) {
    Cloud cloud = RandomCloud(50, 11);
    cloud[3].x() = kNan;
    cloud[17].y() = kInf;
    cloud[40].z() = -kInf;
    const auto decoded = DecodeCloud(GetParam().encode(cloud), /*allow_raw=*/true);
    ASSERT_TRUE(decoded.ok()) << decoded.status();
    EXPECT_EQ(decoded->dropped_nonfinite, 3u);
    Cloud finite;
    for (std::size_t i = 0; i < cloud.size(); ++i) {
        if (i != 3 && i != 17 && i != 40) finite.push_back(cloud[i]);
    }
    EXPECT_TRUE(SameBits(decoded->points, finite));
}

TEST_P(CodecTest, AllNanCloudIsRejected) {
    const Cloud cloud(12, Eigen::Vector3f(kNan, 0.0f, 1.0f));
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(GetParam().encode(cloud), true),
                              "no finite points (12 dropped as NaN/Inf)"));
}

TEST_P(CodecTest, EmptyCloudIsRejected) {
    const std::string bytes = GetParam().encode({});
    const bool raw = GetParam().format == CloudFormat::kRawXyzF32;
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(bytes, true), raw ? "empty" : "no points"));
}

INSTANTIATE_TEST_SUITE_P(AllEncodings, CodecTest, ::testing::ValuesIn(AllCodecs()),
                         [](const auto& param_info) { return param_info.param.name; });

TEST(DecodeCloudTest, EmptyInputIsRejected) {
    EXPECT_TRUE(IsInvalidWith(DecodeCloud("", true), "empty"));
}

TEST(DecodeCloudTest, ThreeRandomBytesAreUnknownFormat) {
    EXPECT_TRUE(IsInvalidWith(DecodeCloud("\x93\x17\xfe"), "unknown cloud format"));
}

TEST(DecodeCloudTest, ThreeRandomBytesAsRawAreNotAMultipleOf12) {
    EXPECT_TRUE(IsInvalidWith(DecodeCloud("\x93\x17\xfe", true), "not a multiple of 12"));
}

TEST(DecodeCloudTest, RawSizeNotMultipleOf12IsRejected) {
    std::string bytes = EncodeRawXyzF32(RandomCloud(4, 3));
    bytes.pop_back();
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(bytes, true), "size 47 bytes is not a multiple of 12"));
}

TEST(DecodeCloudTest, RawWhenNotAllowedIsUnknownFormat) {
    const std::string bytes = EncodeRawXyzF32(RandomCloud(4, 3));
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(bytes, /*allow_raw=*/false), "unknown cloud format"));
}

TEST(DecodeCloudTest, TextThatIsNeitherPlyNorPcdIsUnknownFormat) {
    EXPECT_TRUE(IsInvalidWith(DecodeCloud("solid mesh\nfacet normal 0 0 1\n"),
                              "unknown cloud format (expected PLY or PCD)"));
    EXPECT_TRUE(
        IsInvalidWith(DecodeCloud("# just a comment\n\n# another\n"), "unknown cloud format"));
}

TEST(DecodeCloudTest, LargeBinaryCloudsDecodeCompletely) {
    const Cloud cloud = RandomCloud(100000, 5);
    for (const Codec& codec : AllCodecs()) {
        const auto decoded = DecodeCloud(codec.encode(cloud), true);
        ASSERT_TRUE(decoded.ok()) << codec.name << ": " << decoded.status();
        EXPECT_TRUE(SameBits(decoded->points, cloud)) << codec.name;
    }
}

// Mutations of valid files: every outcome must be OK or InvalidArgument, never a crash.
TEST(DecodeCloudTest, FuzzedInputsNeverCrash) {
    const Cloud cloud = RandomCloud(16, 21);
    std::vector<std::string> seeds;
    for (const Codec& codec : AllCodecs()) seeds.push_back(codec.encode(cloud));
    std::mt19937 rng(1234);
    int ok = 0;
    for (int iteration = 0; iteration < 3000; ++iteration) {
        std::string bytes = seeds[rng() % seeds.size()];
        switch (rng() % 4) {
            case 0:  // flip a few bytes
                for (unsigned k = 0, n = 1 + rng() % 4; k < n; ++k) {
                    bytes[rng() % bytes.size()] = static_cast<char>(rng());
                }
                break;
            case 1:  // truncate
                bytes.resize(rng() % bytes.size());
                break;
            case 2:  // insert random bytes
                bytes.insert(rng() % bytes.size(),
                             std::string(1 + rng() % 8, static_cast<char>(rng())));
                break;
            default:  // replace a digit of the header (counts, sizes)
                for (char& c : bytes) {
                    if (c >= '0' && c <= '9' && rng() % 8 == 0) {
                        c = static_cast<char>('0' + rng() % 10);
                        break;
                    }
                }
                break;
        }
        const auto result = DecodeCloud(bytes, rng() % 2 == 0);
        if (result.ok()) {
            ++ok;
        } else {
            ASSERT_EQ(result.status().code(), absl::StatusCode::kInvalidArgument)
                << result.status();
        }
    }
    EXPECT_GT(ok, 0);
}

}  // namespace
}  // namespace soilvol::io
