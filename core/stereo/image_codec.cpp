#include "core/stereo/image_codec.hpp"

#include <algorithm>
#include <new>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "absl/strings/str_cat.h"
#include "core/stereo/opencv_image.hpp"

namespace soilvol::stereo {

absl::StatusOr<GreyImage> DecodeGrey(std::string_view bytes, std::string_view field,
                                     int max_side_px) {
    absl::StatusOr<cv::Mat> grey = detail::DecodeGreyMat(bytes, field, max_side_px);
    if (!grey.ok()) return grey.status();
    return detail::ToGreyImage(*grey);
}

absl::StatusOr<ScalarImage> DecodeScalar(std::string_view bytes, std::string_view field,
                                         int max_side_px) {
    absl::StatusOr<cv::Mat> decoded = detail::DecodeMat(bytes, field, max_side_px);
    if (!decoded.ok()) return decoded.status();
    const absl::string_view name(field.data(), field.size());
    if (decoded->channels() != 1) {
        return absl::InvalidArgumentError(absl::StrCat(
            name, ": ", decoded->channels(), " channels; a depth or confidence image has one"));
    }
    ScalarImage image{decoded->cols, decoded->rows, 0, {}};
    switch (decoded->depth()) {
        case CV_8U:
            image.bits = 8;
            break;
        case CV_16U:
            image.bits = 16;
            break;
        case CV_32F:
            image.bits = 32;
            break;
        default:
            return absl::InvalidArgumentError(
                absl::StrCat(name, ": samples must be 8 or 16-bit unsigned or 32-bit float"));
    }
    try {
        cv::Mat values;
        decoded->convertTo(values, CV_32F);
        image.values.resize(static_cast<size_t>(values.cols) * values.rows);
        for (int v = 0; v < values.rows; ++v) {
            const float* row = values.ptr<float>(v);
            std::copy(row, row + values.cols,
                      image.values.begin() + static_cast<size_t>(v) * values.cols);
        }
    } catch (const std::bad_alloc&) {
        return absl::InvalidArgumentError(
            absl::StrCat(name, ": too large to decode (out of memory)"));
    }
    return image;
}

absl::StatusOr<std::string> EncodeScalar(const ScalarImage& image) {
    if (image.width <= 0 || image.height <= 0 ||
        image.values.size() != static_cast<size_t>(image.width) * image.height) {
        return absl::InvalidArgumentError(absl::StrCat(
            "image: ", image.values.size(), " values for ", image.width, "x", image.height));
    }
    const int type = image.bits == 8 ? CV_8U : image.bits == 16 ? CV_16U : CV_32F;
    if (image.bits != 8 && image.bits != 16 && image.bits != 32) {
        return absl::InvalidArgumentError(
            absl::StrCat("image: ", image.bits, " bits (8, 16 or 32)"));
    }
    try {
        const cv::Mat floats(image.height, image.width, CV_32F,
                             const_cast<float*>(image.values.data()));
        cv::Mat stored;
        floats.convertTo(stored, type);  // rounds and saturates integers
        std::vector<uchar> bytes;
        if (!cv::imencode(image.bits == 32 ? ".tiff" : ".png", stored, bytes)) {
            return absl::InternalError("image: encoder failed");
        }
        return std::string(bytes.begin(), bytes.end());
    } catch (const std::bad_alloc&) {
        return absl::ResourceExhaustedError("image: out of memory encoding");
    } catch (const std::exception& e) {
        return absl::InternalError(absl::StrCat("image: encoder failed: ", e.what()));
    }
}

absl::StatusOr<std::string> EncodePng(const RgbImage& image) {
    if (image.width <= 0 || image.height <= 0 ||
        image.pixels.size() != static_cast<size_t>(image.width) * image.height * 3) {
        return absl::InvalidArgumentError(absl::StrCat(
            "image: ", image.pixels.size(), " bytes for ", image.width, "x", image.height, " RGB"));
    }
    try {
        cv::Mat rgb(image.height, image.width, CV_8UC3, const_cast<uint8_t*>(image.pixels.data()));
        cv::Mat bgr;
        cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
        std::vector<uchar> png;
        if (!cv::imencode(".png", bgr, png))
            return absl::InternalError("image: PNG encoder failed");
        return std::string(png.begin(), png.end());
    } catch (const std::exception& e) {
        return absl::InternalError(absl::StrCat("image: PNG encoder failed: ", e.what()));
    }
}

absl::StatusOr<std::string> EncodePng(const GreyImage& image) {
    if (image.width <= 0 || image.height <= 0) {
        return absl::InvalidArgumentError(
            absl::StrCat("image: empty (", image.width, "x", image.height, ")"));
    }
    if (image.pixels.size() != static_cast<size_t>(image.width) * image.height) {
        return absl::InvalidArgumentError(absl::StrCat(
            "image: ", image.pixels.size(), " pixels for ", image.width, "x", image.height));
    }
    try {
        std::vector<uchar> png;
        if (!cv::imencode(".png", detail::WrapGrey(image), png)) {
            return absl::InternalError("image: PNG encoder failed");
        }
        return std::string(png.begin(), png.end());
    } catch (const cv::Exception& e) {
        return absl::InternalError(absl::StrCat("image: PNG encoder failed: ", e.what()));
    } catch (const std::bad_alloc&) {
        return absl::ResourceExhaustedError("image: out of memory encoding PNG");
    } catch (const std::exception& e) {
        return absl::InternalError(absl::StrCat("image: PNG encoder failed: ", e.what()));
    }
}

}  // namespace soilvol::stereo
