#include "core/stereo/image_codec.hpp"

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
