#include "core/sim/soil_surface.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <random>

namespace soilvol::sim {

namespace {

// Uniform cubic B-spline weights of controls first..first+3 at grid coordinate u.
struct SplineTap {
    int first = 0;
    std::array<double, 4> weights{};
};

SplineTap Tap(double u, int num_controls) {
    const int cell = std::clamp(static_cast<int>(std::floor(u)), 1, num_controls - 3);
    const double f = std::clamp(u - cell, 0.0, 1.0);
    const double f2 = f * f;
    const double f3 = f2 * f;
    SplineTap tap;
    tap.first = cell - 1;
    tap.weights = {(1.0 - f) * (1.0 - f) * (1.0 - f) / 6.0, (3.0 * f3 - 6.0 * f2 + 4.0) / 6.0,
                   (-3.0 * f3 + 3.0 * f2 + 3.0 * f + 1.0) / 6.0, f3 / 6.0};
    return tap;
}

double Apply(const SplineTap& tap, const double* values, int stride) {
    double sum = 0.0;
    for (int m = 0; m < 4; ++m) sum += tap.weights[m] * values[(tap.first + m) * stride];
    return sum;
}

}  // namespace

SoilSurface::SoilSurface(const ContainerGeometry& container, const SoilSpec& spec, uint64_t seed)
    : container_(container),
      half_x_(0.5 * container.opening_length_m),
      half_y_(0.5 * container.opening_width_m),
      level_z_(spec.fill_height_m - container.depth_m),
      heap_slope_(std::max(spec.heap_slope, 0.0)),
      empty_(!(spec.fill_height_m > 0.0)) {
    const double amplitude = std::max(spec.perturbation_m, 0.0);
    if (amplitude > 0.0 && spec.perturbation_cell_m > 0.0) {
        cell_ = spec.perturbation_cell_m;
        origin_x_ = -half_x_ - cell_;
        origin_y_ = -half_y_ - cell_;
        nx_ = static_cast<int>(std::floor(2.0 * half_x_ / cell_)) + 4;
        ny_ = static_cast<int>(std::floor(2.0 * half_y_ / cell_)) + 4;
        std::mt19937_64 rng(seed);
        std::uniform_real_distribution<double> uniform(-amplitude, amplitude);
        control_.resize(static_cast<size_t>(nx_) * static_cast<size_t>(ny_));
        for (double& value : control_) value = uniform(rng);
    }
    // B-spline weights are a partition of unity, so |p| <= amplitude.
    max_z_ = std::min(level_z_ + amplitude, heap_slope_ * std::min(half_x_, half_y_));
    min_z_ = std::max(-container.depth_m, std::min(level_z_ - amplitude, 0.0));
}

double SoilSurface::Perturbation(double x, double y) const {
    if (control_.empty()) return 0.0;
    const SplineTap tap_x = Tap((x - origin_x_) / cell_, nx_);
    const SplineTap tap_y = Tap((y - origin_y_) / cell_, ny_);
    double sum = 0.0;
    for (int m = 0; m < 4; ++m) {
        const double* row = control_.data() + static_cast<size_t>(tap_y.first + m) * nx_;
        sum += tap_y.weights[m] * Apply(tap_x, row, 1);
    }
    return sum;
}

double SoilSurface::HeapZ(double x, double y) const {
    return heap_slope_ * std::min(half_x_ - std::abs(x), half_y_ - std::abs(y));
}

double SoilSurface::SurfaceZ(double x, double y) const {
    return std::min(level_z_ + Perturbation(x, y), HeapZ(x, y));
}

Eigen::Vector3d SoilSurface::Normal(double x, double y) const {
    constexpr double kStepM = 5e-4;
    const double dz_dx = (SurfaceZ(x + kStepM, y) - SurfaceZ(x - kStepM, y)) / (2.0 * kStepM);
    const double dz_dy = (SurfaceZ(x, y + kStepM) - SurfaceZ(x, y - kStepM)) / (2.0 * kStepM);
    return Eigen::Vector3d(-dz_dx, -dz_dy, 1.0).normalized();
}

bool SoilSurface::Contains(const Eigen::Vector3d& p) const {
    if (empty_ || std::abs(p.x()) >= half_x_ || std::abs(p.y()) >= half_y_) return false;
    if (p.z() >= max_z_ || p.z() <= container_.InnerSurfaceZ(p.x(), p.y())) return false;
    return p.z() < SurfaceZ(p.x(), p.y());
}

double SoilSurface::Volume(double cell_m) const {
    if (empty_) return 0.0;
    if (!(cell_m > 0.0)) cell_m = 0.002;
    const int cols = static_cast<int>(std::ceil(2.0 * half_x_ / cell_m));
    const int rows = static_cast<int>(std::ceil(2.0 * half_y_ / cell_m));
    const double dx = 2.0 * half_x_ / cols;
    const double dy = 2.0 * half_y_ / rows;
    std::vector<double> xs(cols);
    std::vector<SplineTap> taps_x(cols);
    for (int k = 0; k < cols; ++k) {
        xs[k] = -half_x_ + (k + 0.5) * dx;
        if (!control_.empty()) taps_x[k] = Tap((xs[k] - origin_x_) / cell_, nx_);
    }
    // Separable spline: reduce the control grid along y once per row, then along x per cell.
    std::vector<double> row_controls(static_cast<size_t>(nx_), 0.0);
    double sum = 0.0;
    for (int j = 0; j < rows; ++j) {
        const double y = -half_y_ + (j + 0.5) * dy;
        if (!control_.empty()) {
            const SplineTap tap_y = Tap((y - origin_y_) / cell_, ny_);
            for (int i = 0; i < nx_; ++i) row_controls[i] = Apply(tap_y, control_.data() + i, nx_);
        }
        // The inner surface is the profile extruded along x.
        const double inner_z = container_.InnerSurfaceZ(0.0, y);
        const double edge_y = half_y_ - std::abs(y);
        double row_sum = 0.0;
        for (int k = 0; k < cols; ++k) {
            const double p = control_.empty() ? 0.0 : Apply(taps_x[k], row_controls.data(), 1);
            const double heap = heap_slope_ * std::min(half_x_ - std::abs(xs[k]), edge_y);
            row_sum += std::max(0.0, std::min(level_z_ + p, heap) - inner_z);
        }
        sum += row_sum;
    }
    return sum * dx * dy;
}

}  // namespace soilvol::sim
