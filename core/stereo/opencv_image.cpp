#include "core/stereo/opencv_image.hpp"

#include <algorithm>
#include <cstdint>
#include <new>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "core/stereo/image_codec.hpp"
#include "core/stereo/image_header.hpp"

namespace soilvol::stereo::detail {
namespace {

absl::Status TooLarge(absl::string_view field, std::int64_t width, std::int64_t height,
                      int max_side_px) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ": ", width, "x", height, " is larger than ", max_side_px, " px"));
}

// 16-bit grey -> 8-bit: shift right just enough that the largest value fits.
cv::Mat ShiftTo8Bit(const cv::Mat& grey16) {
    double max_value = 0.0;
    cv::minMaxLoc(grey16, nullptr, &max_value);
    int shift = 0;
    while ((static_cast<int>(max_value) >> shift) > 255) ++shift;
    cv::Mat grey8(grey16.size(), CV_8UC1);
    for (int v = 0; v < grey16.rows; ++v) {
        const std::uint16_t* in = grey16.ptr<std::uint16_t>(v);
        std::uint8_t* out = grey8.ptr<std::uint8_t>(v);
        for (int u = 0; u < grey16.cols; ++u) out[u] = static_cast<std::uint8_t>(in[u] >> shift);
    }
    return grey8;
}

absl::StatusOr<cv::Mat> ToGrey(const cv::Mat& decoded, absl::string_view field) {
    const int depth = decoded.depth();
    if (depth != CV_8U && depth != CV_16U) {
        return absl::InvalidArgumentError(
            absl::StrCat(field, ": only 8 or 16-bit unsigned images are supported"));
    }
    cv::Mat grey;
    switch (decoded.channels()) {
        case 1:
            grey = decoded;
            break;
        case 3:
            cv::cvtColor(decoded, grey, cv::COLOR_BGR2GRAY);
            break;
        case 4:
            cv::cvtColor(decoded, grey, cv::COLOR_BGRA2GRAY);
            break;
        default:
            return absl::InvalidArgumentError(
                absl::StrCat(field, ": ", decoded.channels(), " channels (expected 1, 3 or 4)"));
    }
    return depth == CV_16U ? ShiftTo8Bit(grey) : grey;
}

}  // namespace

cv::Mat WrapGrey(const GreyImage& image) {
    return cv::Mat(image.height, image.width, CV_8UC1, const_cast<uint8_t*>(image.pixels.data()));
}

GreyImage ToGreyImage(const cv::Mat& grey) {
    GreyImage image{grey.cols, grey.rows, {}};
    image.pixels.resize(static_cast<size_t>(grey.cols) * grey.rows);
    for (int v = 0; v < grey.rows; ++v) {
        const std::uint8_t* row = grey.ptr<std::uint8_t>(v);
        std::copy(row, row + grey.cols, image.pixels.begin() + static_cast<size_t>(v) * grey.cols);
    }
    return image;
}

absl::StatusOr<cv::Mat> DecodeMat(std::string_view bytes, std::string_view field, int max_side_px,
                                  bool* too_large) {
    const absl::string_view name(field.data(), field.size());
    bool unused = false;
    if (too_large == nullptr) too_large = &unused;
    *too_large = false;
    if (bytes.empty()) return absl::InvalidArgumentError(absl::StrCat(name, ": empty image"));
    const absl::Status undecodable = absl::InvalidArgumentError(
        absl::StrCat(name, ": not a decodable image (PNG, JPEG, BMP, PNM or TIFF)"));
    // Only formats whose header tells the size are decoded, and only within the budget: OpenCV
    // allocates for what a header declares (a 10 KB WebP can declare 16383^2).
    const auto size = PeekImageSize(bytes);
    if (!size) return undecodable;
    if (size->width > max_side_px || size->height > max_side_px) {
        *too_large = true;
        return TooLarge(name, size->width, size->height, max_side_px);
    }
    if (size->width * size->height > kMaxImagePixels) {
        *too_large = true;
        return absl::InvalidArgumentError(absl::StrCat(name, ": ", size->width, "x", size->height,
                                                       " is more than the ", kMaxImagePixels,
                                                       " pixels an image may hold"));
    }
    try {
        const cv::Mat raw(1, static_cast<int>(std::min<size_t>(bytes.size(), INT32_MAX)), CV_8UC1,
                          const_cast<char*>(bytes.data()));
        cv::Mat decoded = cv::imdecode(raw, cv::IMREAD_UNCHANGED);
        if (decoded.empty() || decoded.dims != 2) return undecodable;
        if (decoded.cols > max_side_px || decoded.rows > max_side_px) {
            *too_large = true;
            return TooLarge(name, decoded.cols, decoded.rows, max_side_px);
        }
        return decoded;
    } catch (const cv::Exception&) {
        return undecodable;
    } catch (const std::bad_alloc&) {
        return absl::InvalidArgumentError(
            absl::StrCat(name, ": too large to decode (out of memory)"));
    } catch (const std::exception&) {
        return undecodable;
    }
}

absl::StatusOr<cv::Mat> DecodeGreyMat(std::string_view bytes, std::string_view field,
                                      int max_side_px, bool* too_large) {
    absl::StatusOr<cv::Mat> decoded = DecodeMat(bytes, field, max_side_px, too_large);
    if (!decoded.ok()) return decoded.status();
    const absl::string_view name(field.data(), field.size());
    try {
        return ToGrey(*decoded, name);
    } catch (const std::bad_alloc&) {
        return absl::InvalidArgumentError(
            absl::StrCat(name, ": too large to decode (out of memory)"));
    } catch (const std::exception&) {
        return absl::InvalidArgumentError(absl::StrCat(name, ": cannot convert to grey"));
    }
}

}  // namespace soilvol::stereo::detail
