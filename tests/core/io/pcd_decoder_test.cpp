// PCD decoding through the public DecodeCloud: hand-built files, hostile headers and
// compressed bodies, and compatibility with PCL's own writer and reader.

#include <gtest/gtest.h>
#include <lzf.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_types.h>

#include <cstdint>
#include <cstdio>
#include <fstream>
#include <limits>
#include <string>

#include "core/io/cloud_codec.hpp"
#include "tests/core/io/codec_test_util.hpp"

namespace soilvol::io {
namespace {

using test::Append;
using test::IsInvalidWith;
using test::RandomCloud;
using test::SameBits;

const Cloud kThreePoints = {{1.0f, 2.0f, 3.0f}, {-4.5f, 5.25f, -6.0f}, {0.125f, 1e-3f, 1e6f}};

// Double x/y/z between extra fields, some with COUNT > 1: 40 bytes per point.
std::string ExtraFieldsHeader(std::string_view data) {
    return "# .PCD v0.7 - hand made\nVERSION .7\nFIELDS intensity x y z normal label\n"
           "SIZE 2 8 8 8 4 1\nTYPE U F F F F U\nCOUNT 1 1 1 1 3 2\nWIDTH 3\nHEIGHT 1\n"
           "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 3\nDATA " +
           std::string(data) + "\n";
}

std::string ExtraFieldsBinary() {
    std::string out = ExtraFieldsHeader("binary");
    for (const Eigen::Vector3f& p : kThreePoints) {
        Append<std::uint16_t>(512, &out);
        for (int axis = 0; axis < 3; ++axis) Append<double>(static_cast<double>(p[axis]), &out);
        for (int k = 0; k < 3; ++k) Append<float>(0.5f, &out);
        Append<std::uint16_t>(0xffff, &out);
    }
    return out;
}

// Sizes then LZF data, for a field-by-field buffer.
std::string Compress(const std::string& fields) {
    std::string packed(fields.size() * 2 + 64, '\0');
    const unsigned int size = lzf_compress(fields.data(), static_cast<unsigned int>(fields.size()),
                                           packed.data(), static_cast<unsigned int>(packed.size()));
    std::string out;
    Append<std::uint32_t>(size, &out);
    Append<std::uint32_t>(static_cast<std::uint32_t>(fields.size()), &out);
    return out + packed.substr(0, size);
}

std::string ExtraFieldsCompressed() {
    std::string fields;
    for (const Eigen::Vector3f& p : kThreePoints) {
        (void)p;
        Append<std::uint16_t>(512, &fields);
    }
    for (int axis = 0; axis < 3; ++axis) {
        for (const Eigen::Vector3f& p : kThreePoints) {
            Append<double>(static_cast<double>(p[axis]), &fields);
        }
    }
    fields += std::string(3 * 12 + 3 * 2, '\x01');
    return ExtraFieldsHeader("binary_compressed") + Compress(fields);
}

std::string XyzHeader(std::string_view points_lines, std::string_view data) {
    return "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n" + std::string(points_lines) +
           "DATA " + std::string(data) + "\n";
}

// Offset of the first byte after "DATA ...\n".
std::size_t BodyOffset(const std::string& bytes) {
    return bytes.find('\n', bytes.find("DATA")) + 1;
}

TEST(PcdDecoderTest, DoubleBinaryWithExtraFieldsDecodes) {
    const auto decoded = DecodeCloud(ExtraFieldsBinary());
    ASSERT_TRUE(decoded.ok()) << decoded.status();
    EXPECT_TRUE(SameBits(decoded->points, kThreePoints));
    EXPECT_EQ(decoded->format, CloudFormat::kPcd);
}

TEST(PcdDecoderTest, DoubleCompressedWithExtraFieldsDecodes) {
    const auto decoded = DecodeCloud(ExtraFieldsCompressed());
    ASSERT_TRUE(decoded.ok()) << decoded.status();
    EXPECT_TRUE(SameBits(decoded->points, kThreePoints));
}

TEST(PcdDecoderTest, AsciiWithoutVersionAfterCommentsDecodes) {
    const auto decoded = DecodeCloud(
        "# written by a tool\r\n\r\n# another comment\r\nFIELDS x y z rgb\r\nSIZE 4 4 4 4\r\n"
        "TYPE F F F F\r\nPOINTS 3\r\nDATA ascii\r\n1 2 3 4.2e6\r\n-4.5 5.25 -6 0\r\n"
        "\r\n0.125 0.001 1000000 0 extra\r\n");
    ASSERT_TRUE(decoded.ok()) << decoded.status();
    EXPECT_TRUE(SameBits(decoded->points, kThreePoints));
}

TEST(PcdDecoderTest, AsciiWithDoubleFieldsDecodes) {
    const auto decoded = DecodeCloud(ExtraFieldsHeader("ascii") +
                                     "1 1 2 3 0 0 0 5 5\n2 -4.5 5.25 -6 0 0 0 5 5\n"
                                     "3 0.125 1e-3 1e6 0 0 0 5 5\n");
    ASSERT_TRUE(decoded.ok()) << decoded.status();
    EXPECT_TRUE(SameBits(decoded->points, kThreePoints));
}

TEST(PcdDecoderTest, OrganizedCloudWithNanRowsCountsThem) {
    const auto decoded = DecodeCloud("VERSION 0.7\n" + XyzHeader("WIDTH 2\nHEIGHT 2\n", "ascii") +
                                     "1 2 3\nnan nan nan\n-nan 0 0\n4 5 6\n");
    ASSERT_TRUE(decoded.ok()) << decoded.status();
    EXPECT_EQ(decoded->points.size(), 2u);
    EXPECT_EQ(decoded->dropped_nonfinite, 2u);
}

TEST(PcdDecoderTest, PointsNotWidthTimesHeightIsRejected) {
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(XyzHeader("WIDTH 2\nHEIGHT 2\nPOINTS 5\n", "ascii")),
                              "POINTS 5 != WIDTH * HEIGHT = 2 * 2"));
    EXPECT_TRUE(
        IsInvalidWith(DecodeCloud(XyzHeader("WIDTH 4294967296\nHEIGHT 4294967296\n", "binary")),
                      "WIDTH * HEIGHT overflows"));
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(XyzHeader("HEIGHT 2\n", "binary")), "HEIGHT without"));
}

TEST(PcdDecoderTest, MissingXFieldIsRejected) {
    EXPECT_TRUE(
        IsInvalidWith(DecodeCloud("FIELDS y z\nSIZE 4 4\nTYPE F F\nPOINTS 1\nDATA ascii\n1 2\n"),
                      "missing field 'x'"));
}

TEST(PcdDecoderTest, BadFieldDeclarationsAreRejected) {
    EXPECT_TRUE(IsInvalidWith(
        DecodeCloud("FIELDS x y z\nSIZE 4 4 4\nTYPE I F F\nPOINTS 1\nDATA ascii\n1 2 3\n"),
        "field 'x' must be TYPE F with COUNT 1"));
    EXPECT_TRUE(IsInvalidWith(
        DecodeCloud("FIELDS x y z\nSIZE 4 4\nTYPE F F F\nPOINTS 1\nDATA ascii\n1 2 3\n"),
        "FIELDS has 3 entries but SIZE has 2"));
    EXPECT_TRUE(IsInvalidWith(
        DecodeCloud("FIELDS x y z\nSIZE 4 4 3\nTYPE F F F\nPOINTS 1\nDATA ascii\n1 2 3\n"),
        "SIZE 3 of field 'z' is not 1, 2, 4 or 8"));
    EXPECT_TRUE(IsInvalidWith(DecodeCloud("FIELDS x y z w\nSIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 "
                                          "18446744073709551615\nPOINTS 1\nDATA binary\n"),
                              "point size overflows"));
    EXPECT_TRUE(IsInvalidWith(DecodeCloud("VERSION 0.5\n" + XyzHeader("POINTS 1\n", "ascii")),
                              "unsupported VERSION"));
    EXPECT_TRUE(IsInvalidWith(DecodeCloud("FIELDS a\n" + XyzHeader("POINTS 1\n", "ascii")),
                              "duplicate FIELDS line"));
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(XyzHeader("POINTS 1\n", "zip")),
                              "DATA must be ascii, binary or binary_compressed"));
}

TEST(PcdDecoderTest, ZeroPointsIsRejected) {
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(XyzHeader("WIDTH 0\nHEIGHT 1\n", "binary")),
                              "cloud has no points"));
}

TEST(PcdDecoderTest, HeaderWithoutDataLineIsRejected) {
    EXPECT_TRUE(IsInvalidWith(DecodeCloud("# .PCD v0.7\nFIELDS x y z\nSIZE 4 4 4\n"),
                              "input ends before the DATA line"));
    std::string endless = "# .PCD v0.7\n";
    while (endless.size() < 100000) endless += "# comment comment comment\n";
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(endless), "no DATA line within the first 65536"));
}

TEST(PcdDecoderTest, TruncatedBinaryIsRejected) {
    std::string bytes = ExtraFieldsBinary();
    bytes.pop_back();
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(bytes), "POINTS 3 needs 120 bytes but only 119 follow"));
}

TEST(PcdDecoderTest, AbsurdPointCountIsRejectedBeforeAllocating) {
    const std::string bytes =
        XyzHeader("WIDTH 4000000\nHEIGHT 1\n", "binary") + std::string(20, '\0');
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(bytes), "needs 48000000 bytes but only 20 follow"));
    const std::string ascii = XyzHeader("WIDTH 4000000\nHEIGHT 1\n", "ascii") + "1 2 3\n";
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(ascii), "cannot fit"));
    const std::string huge = XyzHeader("WIDTH 4000000000\nHEIGHT 1\n", "ascii") + "1 2 3\n";
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(huge), "a scan may hold"));
}

TEST(PcdDecoderTest, CompressedSizeBeyondDataIsRejected) {
    std::string bytes = EncodePcd(kThreePoints, PcdEncoding::kBinaryCompressed);
    const std::size_t body = BodyOffset(bytes);
    bytes.replace(body, 4, std::string("\xff\xff\x00\x00", 4));
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(bytes), "compressed size 65535 but"));
    bytes.replace(body, 4, std::string(4, '\0'));
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(bytes), "compressed size 0 but"));
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(bytes.substr(0, body + 6)), "lacks its two size words"));
}

TEST(PcdDecoderTest, AbsurdUncompressedClaimIsRejectedBeforeAllocating) {
    std::string bytes = XyzHeader("WIDTH 3000000\nHEIGHT 1\n", "binary_compressed");
    Append<std::uint32_t>(10, &bytes);
    Append<std::uint32_t>(36000000u, &bytes);
    bytes += std::string(10, '\x1f');
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(bytes), "uncompressed size 36000000 is implausible"));
}

// Issue 12's attack: sizes consistent with the header and a plausible ratio, but a body that
// would expand past what a scan may (4.2 GB peak before "corrupt"). Refused before allocating.
TEST(PcdDecoderTest, CompressedBodyBeyondTheDecodeBudgetIsRejectedBeforeAllocating) {
    // 4.5 million points of 76 bytes (x y z and 16 floats more): 342 MB uncompressed.
    std::string bytes =
        "FIELDS x y z pad\nSIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 16\nWIDTH 4500000\n"
        "HEIGHT 1\nDATA binary_compressed\n";
    constexpr std::uint32_t kUncompressed = 4500000u * 76u;
    constexpr std::uint32_t kCompressed = kUncompressed / 50;
    Append<std::uint32_t>(kCompressed, &bytes);
    Append<std::uint32_t>(kUncompressed, &bytes);
    bytes += std::string(kCompressed, '\x1f');
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(bytes), "bytes a scan may expand to"));
}

TEST(PcdDecoderTest, UncompressedSizeMismatchIsRejected) {
    std::string bytes = EncodePcd(kThreePoints, PcdEncoding::kBinaryCompressed);
    bytes.replace(BodyOffset(bytes) + 4, 4, std::string("\x64\x00\x00\x00", 4));
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(bytes), "uncompressed size 100 != POINTS * point size"));
}

TEST(PcdDecoderTest, CorruptedLzfStreamIsRejected) {
    const std::string valid = EncodePcd(RandomCloud(100, 2), PcdEncoding::kBinaryCompressed);
    const std::size_t stream = BodyOffset(valid) + 8;
    std::string backref_first = valid;
    backref_first[stream] = '\xff';  // a back-reference before any output
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(backref_first), "LZF data is corrupt"));
    std::string cut = valid;
    cut.replace(stream - 8, 4, std::string("\x20\x00\x00\x00", 4));  // only 32 bytes of it
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(cut), "LZF data is corrupt"));
}

TEST(PcdDecoderTest, AsciiGarbageIsRejected) {
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(XyzHeader("POINTS 2\n", "ascii") + "1 2 3\n4 five 6\n"),
                              "point 2: 'five' is not a number"));
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(XyzHeader("POINTS 2\n", "ascii") + "1 2 3\n4 5\n\n\n"),
                              "point 2 has too few values (expected 3)"));
    EXPECT_TRUE(IsInvalidWith(DecodeCloud(XyzHeader("POINTS 2\n", "ascii") + "1 2 3\n      \n"),
                              "expected 2 points but the data ends after 1"));
}

// A unit quaternion of a 30 deg turn about (1, 2, 2) / 3 and a sensor 5 m up.
Pose GantrySensor() {
    Pose pose = Pose::Identity();
    pose.linear() =
        Eigen::AngleAxisd(30.0 * M_PI / 180.0, Eigen::Vector3d(1.0, 2.0, 2.0) / 3.0).matrix();
    pose.translation() = Eigen::Vector3d(3.0, -2.0, 5.0);
    return pose;
}

TEST(PcdDecoderTest, ViewpointIsTheSensorsPose) {
    const Pose sensor = GantrySensor();
    for (const PcdEncoding encoding :
         {PcdEncoding::kAscii, PcdEncoding::kBinary, PcdEncoding::kBinaryCompressed}) {
        const auto decoded = DecodeCloud(EncodePcd(kThreePoints, encoding, sensor));
        ASSERT_TRUE(decoded.ok()) << decoded.status();
        EXPECT_TRUE(decoded->sensor_pose.isApprox(sensor, 1e-12)) << static_cast<int>(encoding);
        EXPECT_EQ(decoded->points, kThreePoints);
    }
    // Absent, and in PLY: the sensor at the origin.
    EXPECT_TRUE(DecodeCloud(XyzHeader("POINTS 1\n", "ascii") + "1 2 3\n")
                    ->sensor_pose.isApprox(Pose::Identity(), 0.0));
    EXPECT_TRUE(DecodeCloud(EncodePly(kThreePoints))->sensor_pose.isApprox(Pose::Identity(), 0.0));
}

TEST(PcdDecoderTest, BadViewpointsAreRejected) {
    const auto with = [](const std::string& viewpoint) {
        return DecodeCloud(XyzHeader("VIEWPOINT " + viewpoint + "\nPOINTS 1\n", "ascii") +
                           "1 2 3\n");
    };
    EXPECT_TRUE(IsInvalidWith(with("0 0 0 1 0 0"), "VIEWPOINT needs 7 numbers, got 6"));
    EXPECT_TRUE(IsInvalidWith(with("0 0 0 1 0 0 0 0"), "VIEWPOINT needs 7 numbers, got 8"));
    EXPECT_TRUE(IsInvalidWith(with("0 0 nan 1 0 0 0"), "VIEWPOINT value 'nan' is not a number"));
    EXPECT_TRUE(IsInvalidWith(with("0 0 1e999 1 0 0 0"), "is not a number"));
    EXPECT_TRUE(IsInvalidWith(with("0 0 0 0 0 0 0"), "is not a unit quaternion (norm 0)"));
    EXPECT_TRUE(IsInvalidWith(with("0 0 0 1 1 0 0"), "is not a unit quaternion"));
    // Written to seven digits, as PCL does: accepted, and normalised.
    const auto rounded = with("1 2 3 0.7071068 0.7071068 0 0");
    ASSERT_TRUE(rounded.ok()) << rounded.status();
    EXPECT_NEAR(Eigen::Quaterniond(rounded->sensor_pose.linear()).norm(), 1.0, 1e-12);
}

// --- Compatibility with PCL's own writer and reader, through temporary files.

std::string TempPath(const std::string& name) {
    return ::testing::TempDir() + "soilvol_io_" + name;
}

std::string ReadFile(const std::string& path) {
    std::ifstream in(path, std::ios::binary | std::ios::ate);
    std::string bytes(static_cast<std::size_t>(in.tellg()), '\0');
    in.seekg(0);
    in.read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    return bytes;
}

pcl::PointCloud<pcl::PointXYZ> ToPcl(const Cloud& cloud) {
    pcl::PointCloud<pcl::PointXYZ> out;
    for (const Eigen::Vector3f& p : cloud) out.push_back({p.x(), p.y(), p.z()});
    return out;
}

TEST(PcdDecoderTest, PclWrittenFilesDecode) {
    Cloud cloud = RandomCloud(500, 17);
    pcl::PointCloud<pcl::PointXYZ> pcl_cloud = ToPcl(cloud);
    pcl_cloud[7].x = std::numeric_limits<float>::quiet_NaN();
    cloud.erase(cloud.begin() + 7);
    const std::string path = TempPath("pcl_written.pcd");
    for (const int mode : {0, 1, 2, 3, 4}) {
        SCOPED_TRACE(mode);
        int written = -1;
        if (mode == 0) written = pcl::io::savePCDFileASCII(path, pcl_cloud);
        if (mode == 1) written = pcl::io::savePCDFileBinary(path, pcl_cloud);
        if (mode == 2) written = pcl::io::savePCDFileBinaryCompressed(path, pcl_cloud);
        if (mode == 3) written = pcl::io::savePLYFileASCII(path, pcl_cloud);
        if (mode == 4) written = pcl::io::savePLYFileBinary(path, pcl_cloud);
        ASSERT_EQ(written, 0);
        const auto decoded = DecodeCloud(ReadFile(path));
        ASSERT_TRUE(decoded.ok()) << decoded.status();
        EXPECT_EQ(decoded->dropped_nonfinite, 1u);
        ASSERT_EQ(decoded->points.size(), cloud.size());
        for (std::size_t i = 0; i < cloud.size(); ++i) {
            EXPECT_LT((decoded->points[i] - cloud[i]).norm(), 1e-4f) << i;
        }
    }
    std::remove(path.c_str());
}

TEST(PcdDecoderTest, PclAndWeAgreeOnTheViewpoint) {
    const Pose sensor = GantrySensor();
    const std::string path = TempPath("viewpoint.pcd");
    std::ofstream(path, std::ios::binary) << EncodePcd(kThreePoints, PcdEncoding::kBinary, sensor);
    pcl::PCLPointCloud2 blob;
    Eigen::Vector4f origin;
    Eigen::Quaternionf orientation;
    ASSERT_EQ(pcl::io::loadPCDFile(path, blob, origin, orientation), 0);
    EXPECT_TRUE(origin.head<3>().isApprox(sensor.translation().cast<float>(), 1e-6f));
    EXPECT_TRUE(orientation.toRotationMatrix().isApprox(sensor.linear().cast<float>(), 1e-6f));
    pcl::PointCloud<pcl::PointXYZ> pcl_cloud = ToPcl(kThreePoints);
    pcl_cloud.sensor_origin_ = origin;
    pcl_cloud.sensor_orientation_ = orientation;
    ASSERT_EQ(pcl::io::savePCDFileBinary(path, pcl_cloud), 0);
    const auto decoded = DecodeCloud(ReadFile(path));
    ASSERT_TRUE(decoded.ok()) << decoded.status();
    EXPECT_TRUE(decoded->sensor_pose.isApprox(sensor, 1e-6));
    std::remove(path.c_str());
}

TEST(PcdDecoderTest, PclReadsOurPcd) {
    const Cloud cloud = RandomCloud(500, 19);
    const std::string path = TempPath("ours.pcd");
    for (const PcdEncoding encoding :
         {PcdEncoding::kAscii, PcdEncoding::kBinary, PcdEncoding::kBinaryCompressed}) {
        SCOPED_TRACE(static_cast<int>(encoding));
        std::ofstream(path, std::ios::binary) << EncodePcd(cloud, encoding);
        pcl::PointCloud<pcl::PointXYZ> loaded;
        ASSERT_EQ(pcl::io::loadPCDFile(path, loaded), 0);
        ASSERT_EQ(loaded.size(), cloud.size());
        for (std::size_t i = 0; i < cloud.size(); ++i) {
            EXPECT_EQ(loaded[i].getVector3fMap(), cloud[i]) << i;
        }
    }
    std::remove(path.c_str());
}

}  // namespace
}  // namespace soilvol::io
