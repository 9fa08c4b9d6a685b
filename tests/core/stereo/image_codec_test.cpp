#include "core/stereo/image_codec.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>
#include <vector>

#include "tests/core/stereo/stereo_test_util.hpp"

namespace soilvol::stereo {
namespace {

using test::IsInvalidWith;

std::string Encode(const cv::Mat& image, const std::string& extension,
                   const std::vector<int>& parameters = {}) {
    std::vector<uchar> bytes;
    EXPECT_TRUE(cv::imencode(extension, image, bytes, parameters));
    return std::string(bytes.begin(), bytes.end());
}

// Seeded noise of the given type in [0, max_value].
cv::Mat RandomMat(int rows, int cols, int type, int max_value, std::uint32_t seed) {
    cv::Mat image(rows, cols, type);
    cv::RNG rng(seed);
    rng.fill(image, cv::RNG::UNIFORM, 0, max_value + 1);
    return image;
}

// A smooth pattern that JPEG keeps within a few grey levels.
cv::Mat SmoothMat(int rows, int cols, int channels) {
    cv::Mat image(rows, cols, CV_8UC(channels));
    for (int v = 0; v < rows; ++v) {
        for (int u = 0; u < cols; ++u) {
            for (int c = 0; c < channels; ++c) {
                image.ptr<uchar>(v)[u * channels + c] =
                    static_cast<uchar>(64 + 2 * u / 3 + v / 2 + 20 * c);
            }
        }
    }
    return image;
}

cv::Mat AsMat(const GreyImage& image) {
    return cv::Mat(image.height, image.width, CV_8UC1,
                   const_cast<std::uint8_t*>(image.pixels.data()))
        .clone();
}

double MeanAbsDifference(const cv::Mat& a, const cv::Mat& b) {
    cv::Mat difference;
    cv::absdiff(a, b, difference);
    return cv::mean(difference)[0];
}

std::uint32_t Crc32(const std::string& bytes) {
    std::uint32_t crc = 0xFFFFFFFFu;
    for (const char c : bytes) {
        crc ^= static_cast<unsigned char>(c);
        for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
    }
    return ~crc;
}

void PutBigEndian32(std::uint32_t value, std::string* bytes, std::size_t offset) {
    for (int i = 0; i < 4; ++i) (*bytes)[offset + i] = static_cast<char>(value >> (24 - 8 * i));
}

// A valid PNG whose IHDR (with a correct CRC) claims width x height.
std::string PngClaiming(std::uint32_t width, std::uint32_t height) {
    std::string png = Encode(RandomMat(8, 8, CV_8UC1, 255, 1), ".png");
    PutBigEndian32(width, &png, 16);
    PutBigEndian32(height, &png, 20);
    PutBigEndian32(Crc32(png.substr(12, 17)), &png, 29);  // over "IHDR" + 13 data bytes
    return png;
}

TEST(DecodeGreyTest, GreyPngDecodesExactly) {
    const cv::Mat image = RandomMat(37, 53, CV_8UC1, 255, 2);
    const auto decoded = DecodeGrey(Encode(image, ".png"), "left");
    ASSERT_TRUE(decoded.ok()) << decoded.status();
    EXPECT_EQ(decoded->width, 53);
    EXPECT_EQ(decoded->height, 37);
    EXPECT_EQ(cv::norm(AsMat(*decoded), image, cv::NORM_INF), 0.0);
}

TEST(DecodeGreyTest, ColourAndAlphaPngBecomeOpenCvGrey) {
    for (const int channels : {3, 4}) {
        const cv::Mat image = RandomMat(20, 30, CV_8UC(channels), 255, 3);
        cv::Mat expected;
        cv::cvtColor(image, expected, channels == 3 ? cv::COLOR_BGR2GRAY : cv::COLOR_BGRA2GRAY);
        const auto decoded = DecodeGrey(Encode(image, ".png"), "left");
        ASSERT_TRUE(decoded.ok()) << decoded.status();
        EXPECT_EQ(cv::norm(AsMat(*decoded), expected, cv::NORM_INF), 0.0) << channels;
    }
}

TEST(DecodeGreyTest, GreyAndColourJpegDecodeWithinJpegError) {
    for (const int channels : {1, 3}) {
        const cv::Mat image = SmoothMat(48, 64, channels);
        cv::Mat expected = image;
        if (channels == 3) cv::cvtColor(image, expected, cv::COLOR_BGR2GRAY);
        const auto decoded =
            DecodeGrey(Encode(image, ".jpg", {cv::IMWRITE_JPEG_QUALITY, 95}), "right");
        ASSERT_TRUE(decoded.ok()) << decoded.status();
        ASSERT_EQ(decoded->width, 64);
        ASSERT_EQ(decoded->height, 48);
        EXPECT_LT(MeanAbsDifference(AsMat(*decoded), expected), 2.0) << channels;
    }
}

TEST(DecodeGreyTest, SixteenBitIsShiftedJustEnough) {
    // Largest value -> shift: 255 -> 0, 256 -> 1, 1023 -> 2, 65535 -> 8.
    for (const auto& [max_value, shift] :
         {std::pair{255, 0}, std::pair{256, 1}, std::pair{1023, 2}, std::pair{65535, 8}}) {
        cv::Mat image = RandomMat(16, 24, CV_16UC1, max_value, 4);
        image.at<std::uint16_t>(5, 7) = static_cast<std::uint16_t>(max_value);
        const auto decoded = DecodeGrey(Encode(image, ".png"), "left");
        ASSERT_TRUE(decoded.ok()) << decoded.status();
        for (int v = 0; v < image.rows; ++v) {
            for (int u = 0; u < image.cols; ++u) {
                ASSERT_EQ(decoded->At(u, v), image.at<std::uint16_t>(v, u) >> shift)
                    << "max " << max_value << " at " << u << "," << v;
            }
        }
    }
}

TEST(DecodeGreyTest, SixteenBitColourIsGreyThenShifted) {
    cv::Mat image = RandomMat(10, 12, CV_16UC3, 4095, 5);
    cv::Mat grey;
    cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
    double max_value = 0.0;
    cv::minMaxLoc(grey, nullptr, &max_value);
    int shift = 0;
    while ((static_cast<int>(max_value) >> shift) > 255) ++shift;
    const auto decoded = DecodeGrey(Encode(image, ".png"), "left");
    ASSERT_TRUE(decoded.ok()) << decoded.status();
    for (int v = 0; v < grey.rows; ++v) {
        for (int u = 0; u < grey.cols; ++u) {
            ASSERT_EQ(decoded->At(u, v), grey.at<std::uint16_t>(v, u) >> shift);
        }
    }
}

TEST(DecodeGreyTest, EmptyGarbageAndTruncatedBytesAreInvalid) {
    EXPECT_TRUE(IsInvalidWith(DecodeGrey("", "left"), "left: empty image"));
    EXPECT_TRUE(
        IsInvalidWith(DecodeGrey("not an image at all", "right"), "right: not a decodable image"));
    const std::string png = Encode(RandomMat(40, 40, CV_8UC1, 255, 6), ".png");
    EXPECT_TRUE(IsInvalidWith(DecodeGrey(png.substr(0, png.size() / 2), "left"),
                              "left: not a decodable image"));
    EXPECT_TRUE(IsInvalidWith(DecodeGrey(png.substr(0, 20), "left"), "left"));
}

TEST(DecodeGreyTest, HugePngHeaderFailsFastBeforeDecoding) {
    for (const std::uint32_t side : {100000u, 30000u}) {  // beyond and within OpenCV's 2^30 px
        const auto start = std::chrono::steady_clock::now();
        const auto decoded = DecodeGrey(PngClaiming(side, side), "left");
        const double seconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        const std::string size = std::to_string(side) + "x" + std::to_string(side);
        EXPECT_TRUE(IsInvalidWith(decoded, "left: " + size + " is larger than 8192 px"));
        EXPECT_LT(seconds, 0.05);
    }
}

// Issue 12: a 10 KB WebP declaring 16383^2 and a JPEG 2000 declaring 16000^2 peaked at 1 GB
// each before the size check; an 8192^2 16-bit PNG decoded fully (3.7 s). Formats whose header
// is not checked are refused unread; a header past the pixel budget is refused unread.
TEST(DecodeGreyTest, UncheckedFormatsAndPixelBudgetAreRefusedBeforeDecoding) {
    const cv::Mat small = SmoothMat(16, 16, 1);
    std::vector<uchar> webp;
    if (cv::imencode(".webp", small, webp)) {
        EXPECT_TRUE(IsInvalidWith(DecodeGrey(std::string(webp.begin(), webp.end()), "left"),
                                  "left: not a decodable image (PNG, JPEG, BMP, PNM or TIFF)"));
    }
    const std::string jp2("\0\0\0\x0cjP  \r\n\x87\n", 12);
    EXPECT_TRUE(IsInvalidWith(DecodeGrey(jp2 + std::string(1000, 'x'), "right"),
                              "right: not a decodable image"));
    const auto start = std::chrono::steady_clock::now();
    const auto square = DecodeGrey(PngClaiming(8192, 8192), "left");
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    EXPECT_TRUE(IsInvalidWith(square, "left: 8192x8192 is more than the 24000000 pixels"));
    EXPECT_LT(seconds, 0.05);
    // Within the budget, a big header is decoded (here: it is truncated, so it fails there).
    EXPECT_TRUE(IsInvalidWith(DecodeGrey(PngClaiming(4000, 3000), "left"), "left"));
}

// Found by fuzz_image_header: a BMP header with a negative width was reported as a negative
// size, which passed the size checks and went to OpenCV. It is no bitmap: refused unread.
TEST(DecodeGreyTest, BmpWithNegativeWidthIsRefusedUnread) {
    std::string bmp = Encode(SmoothMat(8, 8, 1), ".bmp");
    const std::int32_t width = -8;
    for (int i = 0; i < 4; ++i)
        bmp[18 + i] = static_cast<char>(static_cast<std::uint32_t>(width) >> (8 * i));
    EXPECT_TRUE(IsInvalidWith(DecodeGrey(bmp, "left"), "left: not a decodable image"));
}

TEST(DecodeGreyTest, OversizeHeadersOfEachFormatAreRefused) {
    const std::string expected = "left: 9000x10 is larger than 8192 px";
    const cv::Mat small = SmoothMat(8, 8, 1);

    std::string jpeg = Encode(small, ".jpg");
    const std::size_t sof = jpeg.find("\xFF\xC0");
    ASSERT_NE(sof, std::string::npos);
    jpeg[sof + 5] = 0;  // height 10, width 9000 (0x2328), big-endian
    jpeg[sof + 6] = 10;
    jpeg[sof + 7] = 0x23;
    jpeg[sof + 8] = 0x28;
    EXPECT_TRUE(IsInvalidWith(DecodeGrey(jpeg, "left"), expected));

    std::string bmp = Encode(small, ".bmp");
    const std::uint32_t sizes[2] = {9000, 10};
    for (int k = 0; k < 2; ++k) {
        for (int i = 0; i < 4; ++i) bmp[18 + 4 * k + i] = static_cast<char>(sizes[k] >> (8 * i));
    }
    EXPECT_TRUE(IsInvalidWith(DecodeGrey(bmp, "left"), expected));

    EXPECT_TRUE(IsInvalidWith(
        DecodeGrey("P5\n# comment\n9000 10\n255\n" + std::string(64, 'x'), "left"), expected));

    // Little-endian TIFF: header, then an IFD of two LONG entries (ImageWidth, ImageLength).
    std::string tiff("II*\0\x08\0\0\0\x02\0", 10);
    for (const auto& [tag, value] : {std::pair{256, 9000}, std::pair{257, 10}}) {
        const char entry[12] = {
            static_cast<char>(tag & 0xFF),   static_cast<char>(tag >> 8),   4, 0, 1, 0, 0, 0,
            static_cast<char>(value & 0xFF), static_cast<char>(value >> 8), 0, 0};
        tiff.append(entry, sizeof(entry));
    }
    EXPECT_TRUE(IsInvalidWith(DecodeGrey(tiff, "left"), expected));
}

TEST(DecodeGreyTest, SideLimitIsTheCallersChoice) {
    const std::string png = Encode(RandomMat(48, 64, CV_8UC1, 255, 7), ".png");
    EXPECT_TRUE(IsInvalidWith(DecodeGrey(png, "right", 63), "right: 64x48 is larger than 63 px"));
    EXPECT_TRUE(DecodeGrey(png, "right", 64).ok());
}

TEST(EncodePngTest, RoundTripsExactly) {
    GreyImage image{31, 17, {}};
    std::mt19937 rng(8);
    for (int i = 0; i < image.width * image.height; ++i) {
        image.pixels.push_back(static_cast<std::uint8_t>(rng()));
    }
    const auto png = EncodePng(image);
    ASSERT_TRUE(png.ok()) << png.status();
    const auto decoded = DecodeGrey(*png, "image");
    ASSERT_TRUE(decoded.ok()) << decoded.status();
    EXPECT_EQ(decoded->width, image.width);
    EXPECT_EQ(decoded->height, image.height);
    EXPECT_EQ(decoded->pixels, image.pixels);
}

TEST(EncodePngTest, EmptyOrInconsistentImagesAreInvalid) {
    EXPECT_TRUE(IsInvalidWith(EncodePng(GreyImage{}), "empty"));
    EXPECT_TRUE(IsInvalidWith(EncodePng(GreyImage{4, 4, std::vector<std::uint8_t>(15)}),
                              "15 pixels for 4x4"));
}

// Mutations of valid files: every outcome must be OK or InvalidArgument, never a crash.
TEST(DecodeGreyTest, FuzzedImagesNeverCrash) {
    const cv::Mat image = SmoothMat(24, 32, 3);
    const std::vector<std::string> seeds = {Encode(image, ".png"), Encode(image, ".jpg"),
                                            Encode(image, ".bmp"),
                                            Encode(RandomMat(24, 32, CV_16UC1, 65535, 9), ".png")};
    std::mt19937 rng(4321);
    int ok = 0;
    for (int iteration = 0; iteration < 600; ++iteration) {
        std::string bytes = seeds[rng() % seeds.size()];
        switch (rng() % 3) {
            case 0:  // flip a few bytes, headers more often
                for (unsigned k = 0, n = 1 + rng() % 4; k < n; ++k) {
                    const std::size_t span =
                        rng() % 2 == 0 ? std::min<std::size_t>(64, bytes.size()) : bytes.size();
                    bytes[rng() % span] = static_cast<char>(rng());
                }
                break;
            case 1:  // truncate
                bytes.resize(rng() % bytes.size());
                break;
            default:  // insert random bytes
                bytes.insert(rng() % bytes.size(),
                             std::string(1 + rng() % 8, static_cast<char>(rng())));
                break;
        }
        const auto decoded = DecodeGrey(bytes, "left");
        if (decoded.ok()) {
            ++ok;
            EXPECT_EQ(decoded->pixels.size(),
                      static_cast<std::size_t>(decoded->width) * decoded->height);
        } else {
            ASSERT_EQ(decoded.status().code(), absl::StatusCode::kInvalidArgument)
                << decoded.status();
        }
    }
    EXPECT_GT(ok, 0);
}

}  // namespace
}  // namespace soilvol::stereo
