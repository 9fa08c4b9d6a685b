// PLY decoding through the public DecodeCloud: hand-built files and hostile headers/bodies.

#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <string>

#include "core/io/cloud_codec.hpp"
#include "tests/core/io/codec_test_util.hpp"

namespace soilvol::io {
namespace {

using test::Append;
using test::IsInvalidWith;
using test::SameBits;

const Cloud kThree = {{1.0f, 2.0f, 3.0f}, {-4.5f, 5.25f, -6.0f}, {0.125f, 1e-3f, 1e6f}};

// Vertices with double x/y/z among extra properties (rgb, intensity), optionally big-endian.
std::string DoubleVertexPly(bool big_endian) {
    std::string out = std::string("ply\nformat ") +
                      (big_endian ? "binary_big_endian" : "binary_little_endian") +
                      " 1.0\ncomment hand made\nobj_info scanner 7\nelement vertex 3\n"
                      "property uchar red\nproperty double x\nproperty float64 y\n"
                      "property ushort intensity\nproperty double z\nproperty int8 flag\n"
                      "end_header\n";
    for (const Eigen::Vector3f& p : kThree) {
        Append<std::uint8_t>(200, &out, big_endian);
        Append<double>(static_cast<double>(p.x()), &out, big_endian);
        Append<double>(static_cast<double>(p.y()), &out, big_endian);
        Append<std::uint16_t>(40000, &out, big_endian);
        Append<double>(static_cast<double>(p.z()), &out, big_endian);
        Append<std::int8_t>(-1, &out, big_endian);
    }
    return out;
}

// A face element (list property) before and after the vertex element, binary little-endian.
std::string FacesAroundVerticesPly() {
    std::string out =
        "ply\r\nformat binary_little_endian 1.0\r\nelement face 2\r\n"
        "property list uchar int vertex_indices\r\nproperty float quality\r\n"
        "element vertex 3\r\nproperty float x\r\nproperty float y\r\nproperty float z\r\n"
        "property list uint8 uint16 neighbours\r\nelement edge 1\r\nproperty int a\r\n"
        "end_header\r\n";
    for (const int corners : {3, 4}) {
        Append<std::uint8_t>(static_cast<std::uint8_t>(corners), &out);
        for (int i = 0; i < corners; ++i) Append<std::int32_t>(i, &out);
        Append<float>(0.5f, &out);
    }
    for (std::size_t i = 0; i < kThree.size(); ++i) {
        for (int axis = 0; axis < 3; ++axis) Append<float>(kThree[i][axis], &out);
        Append<std::uint8_t>(static_cast<std::uint8_t>(i), &out);
        for (std::size_t k = 0; k < i; ++k) Append<std::uint16_t>(7, &out);
    }
    Append<std::int32_t>(9, &out);
    return out;
}

const char kAsciiFacesAroundVertices[] =
    "ply\nformat ascii 1.0\ncomment made by hand\nelement face 2\n"
    "property list uchar int vertex_indices\nelement vertex 3\nproperty double x\n"
    "property float y\nproperty list uchar float extra\nproperty float z\n"
    "property uchar red\nelement face_after 1\nproperty int a\nend_header\n"
    "3 0 1 2\n\n4 0 1 2 3\n"
    "1 2 0 3 255\n"
    "  -4.5\t5.25 2 9 9 -6.0 0 trailing values ignored \r\n"
    "+0.125 1e-3 1 -7 1e6 17\n"
    "12345\n";

std::string BinaryPly(std::string_view count, std::size_t body_bytes) {
    return std::string("ply\nformat binary_little_endian 1.0\nelement vertex ") +
           std::string(count) + "\nproperty float x\nproperty float y\nproperty float z\n" +
           "end_header\n" + std::string(body_bytes, '\0');
}

std::string AsciiPly(std::string_view properties, std::string_view body) {
    return "ply\nformat ascii 1.0\nelement vertex 2\n" + std::string(properties) + "end_header\n" +
           std::string(body);
}

const char kXyz[] = "property float x\nproperty float y\nproperty float z\n";

TEST(PlyDecoderTest, DoubleLittleEndianWithExtraPropertiesDecodes) {
    const auto decoded = DecodeCloud(DoubleVertexPly(false));
    ASSERT_TRUE(decoded.ok()) << decoded.status();
    EXPECT_TRUE(SameBits(decoded->points, kThree));
    EXPECT_EQ(decoded->format, CloudFormat::kPly);
}

TEST(PlyDecoderTest, DoubleBigEndianWithExtraPropertiesDecodes) {
    const auto decoded = DecodeCloud(DoubleVertexPly(true));
    ASSERT_TRUE(decoded.ok()) << decoded.status();
    EXPECT_TRUE(SameBits(decoded->points, kThree));
}

TEST(PlyDecoderTest, BinaryListElementsAroundVerticesAreSkipped) {
    const auto decoded = DecodeCloud(FacesAroundVerticesPly());
    ASSERT_TRUE(decoded.ok()) << decoded.status();
    EXPECT_TRUE(SameBits(decoded->points, kThree));
}

TEST(PlyDecoderTest, AsciiListsBlankLinesAndExtraTokensAreHandled) {
    const auto decoded = DecodeCloud(kAsciiFacesAroundVertices);
    ASSERT_TRUE(decoded.ok()) << decoded.status();
    EXPECT_TRUE(SameBits(decoded->points, kThree));
}

TEST(PlyDecoderTest, CrlfAsciiDecodes) {
    const auto decoded = DecodeCloud(
        "ply\r\nformat ascii 1.0\r\nelement vertex 1\r\nproperty float x\r\n"
        "property float y\r\nproperty float z\r\nend_header\r\n1 2 3\r\n");
    ASSERT_TRUE(decoded.ok()) << decoded.status();
    EXPECT_TRUE(SameBits(decoded->points, {{1.0f, 2.0f, 3.0f}}));
}

TEST(PlyDecoderTest, TruncatedBinaryPlyIsRejected) {
    std::string bytes = EncodePly(kThree);
    bytes.resize(bytes.size() - 5);
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(bytes), "needs 36 bytes but only 31 follow"));
}

TEST(PlyDecoderTest, TruncatedBinaryListIsRejected) {
    std::string bytes = FacesAroundVerticesPly();
    const std::size_t header_end = bytes.find("end_header\r\n") + 12;
    bytes.resize(header_end + 10);  // inside the second face
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(bytes), "element 'face' is truncated"));
}

TEST(PlyDecoderTest, NegativeListCountIsRejected) {
    std::string bytes =
        "ply\nformat binary_little_endian 1.0\nelement face 1\nproperty list char int v\n"
        "element vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
    Append<std::int8_t>(-3, &bytes);
    bytes += std::string(64, '\0');
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(bytes), "negative list count"));
}

TEST(PlyDecoderTest, HeaderWithoutEndHeaderIsRejected) {
    EXPECT_TRUE(IsInvalidWith(DecodeCloud("ply\nformat ascii 1.0\nelement vertex 1\n"),
                              "input ends before end_header"));
}

TEST(PlyDecoderTest, EndlessHeaderIsRejectedAtTheLimit) {
    std::string bytes = "ply\nformat ascii 1.0\n";
    while (bytes.size() < 200000) bytes += "comment padding padding padding\n";
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(bytes), "no end_header within the first 65536 bytes"));
}

TEST(PlyDecoderTest, EndHeaderWithoutNewlineIsRejected) {
    const std::string bytes =
        std::string("ply\nformat ascii 1.0\nelement vertex 1\n") + kXyz + "end_header";
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(bytes), "end_header must be followed by a newline"));
}

TEST(PlyDecoderTest, AbsurdVertexCountIsRejectedBeforeAllocating) {
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(BinaryPly("4000000", 20)),
                              "vertex count 4000000 needs 48000000 bytes but only 20 follow"));
    // Past the points a scan may hold, the header alone is refused.
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(BinaryPly("5000001", 60000012)), "a scan may hold"));
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(BinaryPly("4000000000", 20)), "a scan may hold"));
}

TEST(PlyDecoderTest, CountTimesStrideOverflowIsRejected) {
    EXPECT_TRUE(
        IsInvalidWith(DecodeCloud(BinaryPly("18446744073709551615", 24)), "a scan may hold"));
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(BinaryPly("99999999999999999999999", 24)),
                              "element line needs a name and a non-negative count"));
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(BinaryPly("-3", 24)), "non-negative count"));
}

TEST(PlyDecoderTest, AbsurdAsciiCountIsRejectedBeforeAllocating) {
    const std::string bytes = std::string("ply\nformat ascii 1.0\nelement vertex 4000000\n") +
                              kXyz + "end_header\n1 2 3\n";
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(bytes), "cannot fit"));
}

TEST(PlyDecoderTest, MissingZPropertyIsRejected) {
    const std::string bytes =
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
        "end_header\n1 2\n";
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(bytes), "vertex element has no 'z' property"));
}

TEST(PlyDecoderTest, BadCoordinatePropertiesAreRejected) {
    EXPECT_TRUE(IsInvalidWith(
        DecodeCloud(AsciiPly("property int x\nproperty float y\nproperty float z\n", "")),
        "vertex property 'x' has type int32; expected float or double"));
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(AsciiPly("property float x\nproperty list uchar float "
                                                   "y\nproperty float z\n",
                                                   "")),
                              "vertex property 'y' is a list"));
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(AsciiPly(std::string(kXyz) + "property float x\n", "")),
                              "vertex property 'x' repeats"));
}

TEST(PlyDecoderTest, MalformedHeaderLinesAreRejected) {
    const std::string xyz = kXyz;
    EXPECT_TRUE(IsInvalidWith(DecodeCloud("ply\nelement vertex 1\n" + xyz + "end_header\n1 2 3\n"),
                              "missing format line"));
    EXPECT_TRUE(IsInvalidWith(
        DecodeCloud("ply\nformat binary_middle_endian 1.0\nelement vertex 1\nend_header\n"),
        "unknown format 'binary_middle_endian'"));
    EXPECT_TRUE(
        IsInvalidWith(DecodeCloud("ply\nformat ascii 2.0\nend_header\n"), "unsupported version"));
    EXPECT_TRUE(IsInvalidWith(DecodeCloud("ply\nformat ascii 1.0\nproperty float x\nend_header\n"),
                              "property before any element"));
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(AsciiPly("property float128 w\n" + xyz, "")),
                              "unknown property type 'float128'"));
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(AsciiPly("texture foo.png\n" + xyz, "")),
                              "unknown keyword 'texture'"));
    EXPECT_TRUE(IsInvalidWith(DecodeCloud("ply\nformat ascii 1.0\nelement face 1\nend_header\n"),
                              "no vertex element"));
}

TEST(PlyDecoderTest, ZeroVerticesIsRejected) {
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(BinaryPly("0", 0)), "cloud has no points"));
}

TEST(PlyDecoderTest, AsciiNonNumericTokenIsRejected) {
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(AsciiPly(kXyz, "1 2 3\n4 abc 6\n")),
                              "vertex 2: 'abc' is not a number (property 'y')"));
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(AsciiPly(kXyz, "1 2 3\n4 5 6x\n")), "'6x'"));
}

TEST(PlyDecoderTest, AsciiTooFewValuesIsRejected) {
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(AsciiPly(kXyz, "1 2 3\n4 5\n\n\n\n")),
                              "vertex 2 has too few values"));
}

TEST(PlyDecoderTest, AsciiTooFewLinesIsRejected) {
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(AsciiPly(kXyz, "1 2 3\n\n   \n")),
                              "expected 2 vertex lines but the data ends after 1"));
}

TEST(PlyDecoderTest, AsciiOutOfRangeFloatBecomesNonFinite) {
    const auto decoded = DecodeCloud(AsciiPly(kXyz, "1 2 3\n1e39 5 6\n"));
    ASSERT_TRUE(decoded.ok()) << decoded.status();
    EXPECT_EQ(decoded->points.size(), 1u);
    EXPECT_EQ(decoded->dropped_nonfinite, 1u);
}

// Mutations of the hand-built files above, lists included: OK or InvalidArgument only.
TEST(PlyDecoderTest, FuzzedHandBuiltFilesNeverCrash) {
    const std::string seeds[] = {DoubleVertexPly(false), DoubleVertexPly(true),
                                 FacesAroundVerticesPly(), kAsciiFacesAroundVertices};
    std::mt19937 rng(99);
    for (int iteration = 0; iteration < 2000; ++iteration) {
        std::string bytes = seeds[rng() % 4];
        if (rng() % 3 == 0) bytes.resize(rng() % bytes.size());
        for (unsigned k = 0, n = rng() % 4; k < n && !bytes.empty(); ++k) {
            bytes[rng() % bytes.size()] = static_cast<char>(rng());
        }
        const auto result = DecodeCloud(bytes);
        if (!result.ok()) {
            ASSERT_EQ(result.status().code(), absl::StatusCode::kInvalidArgument)
                << result.status();
        }
    }
}

}  // namespace
}  // namespace soilvol::io
