#include "core/stereo/pixel_corners.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "absl/strings/str_cat.h"
#include "core/common/polygon.hpp"

namespace soilvol::stereo {
namespace {

struct Sample {
    double u, v, d;
};

double SegmentDistance(const Eigen::Vector2d& p, const Eigen::Vector2d& a,
                       const Eigen::Vector2d& b) {
    const Eigen::Vector2d ab = b - a;
    const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
    return (p - (a + t * ab)).norm();
}

// Valid disparities within band_px of the closed polygon's edges.
std::vector<Sample> BandSamples(const DisparityMap& disparity,
                                const std::array<Eigen::Vector2d, 4>& px, double band_px) {
    std::vector<Sample> samples;
    for (int e = 0; e < 4; ++e) {
        const Eigen::Vector2d& a = px[e];
        const Eigen::Vector2d& b = px[(e + 1) % 4];
        const int u0 = std::max(0, static_cast<int>(std::floor(std::min(a.x(), b.x()) - band_px)));
        const int u1 = std::min(disparity.width - 1,
                                static_cast<int>(std::ceil(std::max(a.x(), b.x()) + band_px)));
        const int v0 = std::max(0, static_cast<int>(std::floor(std::min(a.y(), b.y()) - band_px)));
        const int v1 = std::min(disparity.height - 1,
                                static_cast<int>(std::ceil(std::max(a.y(), b.y()) + band_px)));
        for (int v = v0; v <= v1; ++v) {
            for (int u = u0; u <= u1; ++u) {
                const float d = disparity.At(u, v);
                if (!(d > 0.0f) || SegmentDistance({u, v}, a, b) > band_px) continue;
                samples.push_back(
                    {static_cast<double>(u), static_cast<double>(v), static_cast<double>(d)});
            }
        }
    }
    return samples;
}

bool SolvePlane(const std::vector<Sample>& samples, const std::vector<std::size_t>& indices,
                Eigen::Vector3d* plane) {
    Eigen::MatrixXd a(indices.size(), 3);
    Eigen::VectorXd b(indices.size());
    for (std::size_t i = 0; i < indices.size(); ++i) {
        const Sample& s = samples[indices[i]];
        a.row(static_cast<Eigen::Index>(i)) << s.u, s.v, 1.0;
        b(static_cast<Eigen::Index>(i)) = s.d;
    }
    Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(a);
    if (qr.rank() < 3) return false;
    *plane = qr.solve(b);
    return plane->allFinite();
}

std::vector<std::size_t> Inliers(const std::vector<Sample>& samples, const Eigen::Vector3d& plane,
                                 double tolerance) {
    std::vector<std::size_t> inliers;
    for (std::size_t i = 0; i < samples.size(); ++i) {
        const Sample& s = samples[i];
        if (std::abs(plane.dot(Eigen::Vector3d(s.u, s.v, 1.0)) - s.d) <= tolerance) {
            inliers.push_back(i);
        }
    }
    return inliers;
}

absl::Status CheckPixels(const PixelCorners& corners, int width, int height) {
    for (int i = 0; i < 4; ++i) {
        const Eigen::Vector2d& c = corners[i];
        if (!c.allFinite() || c.x() < -0.5 || c.y() < -0.5 || c.x() > width - 0.5 ||
            c.y() > height - 0.5) {
            return absl::InvalidArgumentError(absl::StrCat("pixel corner ", i, " (", c.x(), ", ",
                                                           c.y(), ") is outside the ", width, "x",
                                                           height, " image"));
        }
    }
    return absl::OkStatus();
}

}  // namespace

absl::StatusOr<LiftedCorners> LiftPixelCorners(const StereoReconstructor& reconstructor,
                                               const DisparityMap& disparity,
                                               const PixelCorners& corners_px,
                                               const PixelCornerConfig& config) {
    const StereoParameters& p = reconstructor.calibration().parameters;
    if (auto status = CheckPixels(corners_px, p.image_width, p.image_height); !status.ok()) {
        return status;
    }
    if (disparity.width != p.image_width || disparity.height != p.image_height) {
        return absl::InvalidArgumentError("disparity map does not match the calibration");
    }
    LiftedCorners lifted;
    std::vector<Eigen::Vector2d> polygon;
    for (int i = 0; i < 4; ++i) {
        lifted.rectified_px[i] = reconstructor.RectifyLeftPixel(corners_px[i]);
        polygon.push_back(lifted.rectified_px[i]);
    }
    for (int i = 0; i < 4; ++i) {
        if ((polygon[(i + 1) % 4] - polygon[i]).norm() < config.min_edge_px) {
            return absl::InvalidArgumentError(absl::StrCat("pixel corners ", i, " and ",
                                                           (i + 1) % 4, " are closer than ",
                                                           config.min_edge_px, " px"));
        }
    }
    if (!Polygon2d(polygon).IsSimple()) {
        return absl::InvalidArgumentError(
            "pixel corners are not in order around the opening (the edges cross)");
    }

    // Fit the rim plane in disparity space.
    const std::vector<Sample> samples = BandSamples(disparity, lifted.rectified_px, config.band_px);
    lifted.band_pixels = samples.size();
    if (samples.size() < config.min_inliers) {
        return absl::FailedPreconditionError(
            absl::StrCat("only ", samples.size(), " valid disparities along the marked rim (",
                         config.min_inliers, " needed): is the rim visible in both images?"));
    }
    std::mt19937_64 rng(config.seed);
    std::uniform_int_distribution<std::size_t> pick(0, samples.size() - 1);
    std::vector<std::size_t> best;
    for (int it = 0; it < config.ransac_iterations; ++it) {
        Eigen::Vector3d plane;
        if (!SolvePlane(samples, {pick(rng), pick(rng), pick(rng)}, &plane)) continue;
        std::vector<std::size_t> inliers = Inliers(samples, plane, config.inlier_px);
        if (inliers.size() > best.size()) best = std::move(inliers);
    }
    for (int refit = 0; refit < 2 && best.size() >= 3; ++refit) {
        if (!SolvePlane(samples, best, &lifted.plane)) break;
        best = Inliers(samples, lifted.plane, config.inlier_px);
    }
    lifted.inliers = best.size();
    if (best.size() < config.min_inliers) {
        return absl::FailedPreconditionError(
            absl::StrCat("no rim plane fits the marked corners: ", best.size(), " of ",
                         samples.size(), " disparities agree (", config.min_inliers, " needed)"));
    }
    double sum2 = 0.0;
    for (std::size_t i : best) {
        const Sample& s = samples[i];
        const double r = lifted.plane.dot(Eigen::Vector3d(s.u, s.v, 1.0)) - s.d;
        sum2 += r * r;
    }
    lifted.rms_px = std::sqrt(sum2 / best.size());

    // Each corner at the plane's disparity.
    for (int i = 0; i < 4; ++i) {
        const Eigen::Vector2d& px = lifted.rectified_px[i];
        const double d = lifted.plane.dot(Eigen::Vector3d(px.x(), px.y(), 1.0));
        if (!(d > 0.0)) {
            return absl::FailedPreconditionError(
                absl::StrCat("the rim plane puts corner ", i, " at infinity (disparity ", d, ")"));
        }
        lifted.corners[i] = reconstructor.Reproject(px.x(), px.y(), d);
    }
    return lifted;
}

}  // namespace soilvol::stereo
