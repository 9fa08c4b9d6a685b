#include "core/sim/tof_camera.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>

#include "core/sim/soil_surface.hpp"

namespace soilvol::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kEdgeRatio = 0.03;
constexpr int kMultipathWindowPx = 6;
constexpr double kConcaveCos = 0.87;  // normals more than 30 deg apart

// The first hits of every pixel's centre ray (container frame), with the rays (camera frame),
// and what the pixel's whole footprint returns.
struct Hits {
    std::vector<Eigen::Vector3d> ray;     ///< unit, camera frame
    std::vector<double> range;            ///< 0: miss
    std::vector<Eigen::Vector3d> point;   ///< container frame
    std::vector<Eigen::Vector3d> normal;  ///< container frame, facing the camera
    std::vector<double> mixed_range;      ///< the footprint's amplitude-weighted range
    std::vector<double> other_share;      ///< amplitude share of other surfaces in it
    std::vector<double> other_range;      ///< their amplitude-weighted range
};

struct Return {
    double range = 0.0;
    double amplitude = 0.0;
};

Return CastRay(const SceneRaycaster& scene, const Pose& T_container_scan,
               const Eigen::Vector3d& ray, RayHit* hit_out = nullptr) {
    constexpr double kMaxRange = 50.0;
    const Eigen::Vector3d direction = T_container_scan.linear() * ray;
    const auto hit = scene.CastHit(T_container_scan.translation(), direction, kMaxRange);
    if (!hit) return {};
    if (hit_out != nullptr) *hit_out = *hit;
    const double incidence_cos = std::max(0.0, -direction.dot(hit->normal));
    return {hit->distance, incidence_cos / (hit->distance * hit->distance)};
}

// A pixel's footprint, sampled on a footprint_samples^2 grid of sub-rays: the light of all of
// them, amplitude-weighted (the phases of nearby depths add as their mean); sub-rays whose
// range differs from the centre ray's by more than kEdgeRatio saw another surface.
void IntegrateFootprint(const SceneRaycaster& scene, const Pose& T_container_scan,
                        const CameraIntrinsics& k, int u, int v, int samples, double centre,
                        Hits& hits, std::size_t i) {
    double weight = 0.0, weighted = 0.0, other_weight = 0.0, other_weighted = 0.0;
    for (int sv = 0; sv < samples; ++sv) {
        for (int su = 0; su < samples; ++su) {
            const double x = u - 0.5 + (su + 0.5) / samples;
            const double y = v - 0.5 + (sv + 0.5) / samples;
            const Eigen::Vector3d ray = Eigen::Vector3d((x - k.cx) / k.fx, (y - k.cy) / k.fy, 1.0);
            const Return r = CastRay(scene, T_container_scan, ray.normalized());
            if (r.amplitude <= 0.0) continue;
            weight += r.amplitude;
            weighted += r.amplitude * r.range;
            if (centre <= 0.0 || std::abs(r.range - centre) > kEdgeRatio * centre) {
                other_weight += r.amplitude;
                other_weighted += r.amplitude * r.range;
            }
        }
    }
    if (weight <= 0.0 || centre <= 0.0) return;
    hits.mixed_range[i] = weighted / weight;
    hits.other_share[i] = other_weight / weight;
    hits.other_range[i] = other_weight > 0.0 ? other_weighted / other_weight : 0.0;
}

Hits CastAll(const SceneRaycaster& scene, const Pose& T_scan_container, const CameraIntrinsics& k,
             int width, int height, int footprint_samples) {
    const Pose T_container_scan = T_scan_container.inverse();
    const std::size_t n = static_cast<std::size_t>(width) * height;
    Hits hits{std::vector<Eigen::Vector3d>(n),
              std::vector<double>(n, 0.0),
              std::vector<Eigen::Vector3d>(n, Eigen::Vector3d::Zero()),
              std::vector<Eigen::Vector3d>(n, Eigen::Vector3d::UnitZ()),
              std::vector<double>(n, 0.0),
              std::vector<double>(n, 0.0),
              std::vector<double>(n, 0.0)};
#pragma omp parallel for schedule(dynamic, 4)
    for (int v = 0; v < height; ++v) {
        for (int u = 0; u < width; ++u) {
            const std::size_t i = static_cast<std::size_t>(v) * width + u;
            hits.ray[i] = Eigen::Vector3d((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0).normalized();
            RayHit hit{};
            const Return centre = CastRay(scene, T_container_scan, hits.ray[i], &hit);
            if (centre.range > 0.0) {
                hits.range[i] = hit.distance;
                hits.point[i] = T_container_scan.translation() +
                                hit.distance * (T_container_scan.linear() * hits.ray[i]);
                hits.normal[i] = hit.normal;
            }
            hits.mixed_range[i] = hits.range[i];
        }
    }
    if (footprint_samples <= 1) return hits;
    // A footprint on one smooth surface returns its centre's range (to second order, as the
    // sub-rays lie symmetrically about it); only pixels whose 8-neighbours' centre ranges jump
    // (or miss) can straddle an edge, and only they are integrated. An edge thinner than the
    // pixel pitch between two centre rays is not seen.
    const auto at_edge = [&](int u, int v) {
        const double r = hits.range[static_cast<std::size_t>(v) * width + u];
        for (int dv = -1; dv <= 1; ++dv) {
            for (int du = -1; du <= 1; ++du) {
                const int uu = u + du;
                const int vv = v + dv;
                if (uu < 0 || vv < 0 || uu >= width || vv >= height) continue;
                const double near = hits.range[static_cast<std::size_t>(vv) * width + uu];
                if ((near <= 0.0) != (r <= 0.0) || std::abs(near - r) > 0.5 * kEdgeRatio * r) {
                    return true;
                }
            }
        }
        return false;
    };
#pragma omp parallel for schedule(dynamic, 4)
    for (int v = 0; v < height; ++v) {
        for (int u = 0; u < width; ++u) {
            const std::size_t i = static_cast<std::size_t>(v) * width + u;
            if (hits.range[i] > 0.0 && at_edge(u, v)) {
                IntegrateFootprint(scene, T_container_scan, k, u, v, footprint_samples,
                                   hits.range[i], hits, i);
            }
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
    const Hits hits = CastAll(scene, T_scan_container, frame.intrinsics, w, h,
                              spec.flying_pixels ? spec.footprint_samples : 1);
    std::vector<double> amplitude(n);
    for (std::size_t i = 0; i < n; ++i) amplitude[i] = Amplitude(hits, T_scan_container, i);
    const std::vector<double>& range = hits.mixed_range;
    frame.mix_share.assign(n, 0.0f);
    frame.other_range_m.assign(n, 0.0f);
    for (std::size_t i = 0; i < n; ++i) {
        frame.mix_share[i] = static_cast<float>(hits.other_share[i]);
        frame.other_range_m[i] = static_cast<float>(hits.other_range[i]);
    }
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

TofCameraSpec TypicalTofCamera() {
    TofCameraSpec camera;
    camera.width = 640;
    camera.height = 480;
    camera.horizontal_fov_deg = 67.0;
    camera.noise_at_1m_m = 0.003;
    camera.multipath_m = 0.02;
    return camera;
}

TofScene SimulateTofScene(const SceneSpec& spec, const TofCameraSpec& camera) {
    const ContainerGeometry container =
        spec.shape ? MakeContainer(*spec.shape) : MakeContainer(spec.container);
    const SoilSurface soil(container, spec.soil, spec.soil_seed);
    std::mt19937_64 rng(spec.scan_seed);
    TofScene out{PlaceScene(spec, container, soil, &rng), {}};
    out.frame =
        RenderTof(SceneRaycaster(container, soil), out.scene.T_scan_container, camera, &rng);
    return out;
}

}  // namespace soilvol::sim
