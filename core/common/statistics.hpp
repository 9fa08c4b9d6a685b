#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace soilvol {

/// The q-quantile (0 <= q <= 1, nearest rank below) of `values`; NaN when empty. Reorders
/// `values`.
template <class T>
double QuantileInPlace(std::vector<T>& values, double q) {
    if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
    const double clamped = std::clamp(q, 0.0, 1.0);
    const auto k = static_cast<long>(clamped * static_cast<double>(values.size() - 1));
    std::nth_element(values.begin(), values.begin() + k, values.end());
    return static_cast<double>(values[static_cast<std::size_t>(k)]);
}

/// The q-quantile of a copy of `values`.
template <class T>
double Quantile(std::vector<T> values, double q) {
    return QuantileInPlace(values, q);
}

/// Median (upper middle element) of a copy of `values`; NaN when empty.
template <class T>
double Median(std::vector<T> values) {
    if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
    const auto mid = values.begin() + static_cast<long>(values.size() / 2);
    std::nth_element(values.begin(), mid, values.end());
    return static_cast<double>(*mid);
}

/// 1.4826 x the median absolute deviation from `centre`: a robust sigma for Gaussian data.
template <class T>
double RobustSigma(const std::vector<T>& values, double centre) {
    std::vector<double> dev;
    dev.reserve(values.size());
    for (const T& v : values) dev.push_back(std::abs(static_cast<double>(v) - centre));
    return 1.4826 * Median(std::move(dev));
}

/// Mean and standard deviation (n - 1 in the denominator, n the total weight) of `values`
/// each counted `weight(i)` times; NaN mean when the total weight is zero.
struct MeanSd {
    double mean = std::numeric_limits<double>::quiet_NaN();
    double sd = 0.0;
};

template <class T, class WeightFn>
MeanSd WeightedMeanSd(const std::vector<T>& values, WeightFn weight) {
    double n = 0.0, sum = 0.0;
    for (std::size_t i = 0; i < values.size(); ++i) {
        n += weight(i);
        sum += weight(i) * static_cast<double>(values[i]);
    }
    MeanSd r;
    if (n <= 0.0) return r;
    r.mean = sum / n;
    double sq = 0.0;
    for (std::size_t i = 0; i < values.size(); ++i) {
        const double d = static_cast<double>(values[i]) - r.mean;
        sq += weight(i) * d * d;
    }
    r.sd = std::sqrt(sq / std::max(n - 1.0, 1.0));
    return r;
}

}  // namespace soilvol
