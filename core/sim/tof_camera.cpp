#include "core/sim/tof_camera.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>

namespace soilvol::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kEdgeRatio = 0.03;
constexpr int kMultipathWindowPx = 6;
constexpr double kConcaveCos = 0.87;  // normals more than 30 deg apart

// The first hits of every pixel's centre ray (container frame), with the rays (camera frame).
struct Hits {
    std::vector<Eigen::Vector3d> ray;     ///< unit, camera frame
    std::vector<double> range;            ///< 0: miss
    std::vector<Eigen::Vector3d> point;   ///< container frame
    std::vector<Eigen::Vector3d> normal;  ///< container frame, facing the camera
};

Hits CastAll(const SceneRaycaster& scene, const Pose& T_scan_container, const CameraIntrinsics& k,
             int width, int height) {
    const Pose T_container_scan = T_scan_container.inverse();
    const Eigen::Vector3d origin = T_container_scan.translation();
    const std::size_t n = static_cast<std::size_t>(width) * height;
    Hits hits{std::vector<Eigen::Vector3d>(n), std::vector<double>(n, 0.0),
              std::vector<Eigen::Vector3d>(n, Eigen::Vector3d::Zero()),
              std::vector<Eigen::Vector3d>(n, Eigen::Vector3d::UnitZ())};
    const double max_range = 50.0;
#pragma omp parallel for schedule(dynamic, 4)
    for (int v = 0; v < height; ++v) {
        for (int u = 0; u < width; ++u) {
            const std::size_t i = static_cast<std::size_t>(v) * width + u;
            hits.ray[i] = Eigen::Vector3d((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0).normalized();
            const Eigen::Vector3d direction = T_container_scan.linear() * hits.ray[i];
            const auto hit = scene.CastHit(origin, direction, max_range);
            if (!hit) continue;
            hits.range[i] = hit->distance;
            hits.point[i] = origin + hit->distance * direction;
            hits.normal[i] = hit->normal;
        }
    }
    return hits;
}

double Amplitude(const Hits& hits, const Pose& T_scan_container, std::size_t i) {
    if (hits.range[i] <= 0.0) return 0.0;
    const Eigen::Vector3d ray = T_scan_container.linear().transpose() * hits.ray[i];
    const double incidence_cos = std::max(0.0, -ray.dot(hits.normal[i]));
    return incidence_cos / (hits.range[i] * hits.range[i]);
}

// Mixes the returns across depth edges: for each pair of 4-neighbours whose ranges differ by
// more than kEdgeRatio, the edge lies in one of the two (chosen at random), covering a uniform
// share of it with the other surface; the range is the amplitude-weighted mean (phase mixing).
void MixAcrossEdges(const std::vector<double>& amplitude, int width, int height,
                    std::vector<double>& range, TofFrame& frame, std::mt19937_64* rng) {
    std::vector<float>& share = frame.mix_share;
    const std::vector<double> pure = range;
    std::uniform_real_distribution<double> uniform(0.0, 1.0);
    const auto mix = [&](std::size_t a, std::size_t b) {
        if (pure[a] <= 0.0 || pure[b] <= 0.0) return;
        if (std::abs(pure[a] - pure[b]) <= kEdgeRatio * std::min(pure[a], pure[b])) return;
        const bool in_a = uniform(*rng) < 0.5;
        const std::size_t m = in_a ? a : b;
        const std::size_t o = in_a ? b : a;
        if (share[m] > 0.0f) return;  // already mixed across another edge
        const double s = uniform(*rng);
        const double w_other = s * amplitude[o];
        const double w_self = (1.0 - s) * amplitude[m];
        if (w_other + w_self <= 0.0) return;
        range[m] = (w_self * pure[m] + w_other * pure[o]) / (w_self + w_other);
        share[m] = static_cast<float>(s);
        frame.other_range_m[m] = static_cast<float>(pure[o]);
    };
    for (int v = 0; v < height; ++v) {
        for (int u = 0; u < width; ++u) {
            const std::size_t i = static_cast<std::size_t>(v) * width + u;
            if (u + 1 < width) mix(i, i + 1);
            if (v + 1 < height) mix(i, i + static_cast<std::size_t>(width));
        }
    }
}

// The multipath bias per pixel: light from facing surfaces nearby (a concave corner), summed
// over the pixel's neighbourhood in the image.
std::vector<double> MultipathBias(const Hits& hits, int width, int height,
                                  const TofCameraSpec& spec) {
    std::vector<double> bias(hits.range.size(), 0.0);
    if (spec.multipath_m <= 0.0) return bias;
#pragma omp parallel for schedule(dynamic, 4)
    for (int v = 0; v < height; ++v) {
        for (int u = 0; u < width; ++u) {
            const std::size_t i = static_cast<std::size_t>(v) * width + u;
            if (hits.range[i] <= 0.0) continue;
            double strongest = 0.0;
            for (int dv = -kMultipathWindowPx; dv <= kMultipathWindowPx; dv += 2) {
                for (int du = -kMultipathWindowPx; du <= kMultipathWindowPx; du += 2) {
                    const int uu = u + du;
                    const int vv = v + dv;
                    if (uu < 0 || vv < 0 || uu >= width || vv >= height) continue;
                    const std::size_t j = static_cast<std::size_t>(vv) * width + uu;
                    if (hits.range[j] <= 0.0) continue;
                    const Eigen::Vector3d d = hits.point[j] - hits.point[i];
                    const double distance = d.norm();
                    // Each in front of the other, and turned: a concave corner.
                    if (distance < 1e-6 || d.dot(hits.normal[i]) <= 0.0 ||
                        (-d).dot(hits.normal[j]) <= 0.0 ||
                        hits.normal[i].dot(hits.normal[j]) > kConcaveCos) {
                        continue;
                    }
                    strongest = std::max(strongest, std::exp(-distance / spec.multipath_reach_m));
                }
            }
            bias[i] = spec.multipath_m * strongest;
        }
    }
    return bias;
}

}  // namespace

TofFrame RenderTof(const SceneRaycaster& scene, const Pose& T_scan_container,
                   const TofCameraSpec& spec, std::mt19937_64* rng) {
    const int w = spec.width;
    const int h = spec.height;
    const double f = 0.5 * w / std::tan(0.5 * spec.horizontal_fov_deg * kPi / 180.0);
    TofFrame frame;
    frame.intrinsics = {f, f, (w - 1) / 2.0, (h - 1) / 2.0, {}};
    const std::size_t n = static_cast<std::size_t>(w) * h;
    const Hits hits = CastAll(scene, T_scan_container, frame.intrinsics, w, h);
    std::vector<double> amplitude(n);
    for (std::size_t i = 0; i < n; ++i) amplitude[i] = Amplitude(hits, T_scan_container, i);
    std::vector<double> range = hits.range;
    frame.mix_share.assign(n, 0.0f);
    frame.other_range_m.assign(n, 0.0f);
    if (spec.flying_pixels) MixAcrossEdges(amplitude, w, h, range, frame, rng);
    const std::vector<double> bias = MultipathBias(hits, w, h, spec);
    frame.depth = {w, h, 32, std::vector<float>(n, 0.0f)};
    frame.amplitude = {w, h, 32, std::vector<float>(n, 0.0f)};
    frame.true_range_m.assign(n, 0.0f);
    frame.multipath_m.assign(n, 0.0f);
    std::normal_distribution<double> normal(0.0, 1.0);
    for (std::size_t i = 0; i < n; ++i) {
        frame.true_range_m[i] = static_cast<float>(hits.range[i]);
        frame.amplitude.values[i] = static_cast<float>(amplitude[i]);
        if (range[i] <= 0.0 || amplitude[i] < spec.min_amplitude) continue;
        const double incidence_cos = amplitude[i] * hits.range[i] * hits.range[i];
        const double sigma =
            spec.noise_at_1m_m * range[i] / std::sqrt(std::max(incidence_cos, 1e-3));
        const double measured = range[i] + bias[i] + sigma * normal(*rng);
        frame.multipath_m[i] = static_cast<float>(bias[i]);
        if (measured <= 0.0) continue;
        frame.depth.values[i] = static_cast<float>(measured * hits.ray[i].z());
    }
    return frame;
}

}  // namespace soilvol::sim
