#include "core/cloud/candidate_block.hpp"

namespace soilvol::cloud {

void CandidateBlock::Load(const Cloud& points, const Eigen::Vector3f& anchor,
                          const std::vector<float>& weights) {
    anchor_ = anchor;
    const std::size_t n = index_.size();
    x_.resize(n);
    y_.resize(n);
    z_.resize(n);
    w_.resize(n);
    for (std::size_t j = 0; j < n; ++j) {
        const Eigen::Vector3f q = points[index_[j]] - anchor;
        x_[j] = q.x();
        y_[j] = q.y();
        z_[j] = q.z();
        w_[j] = weights.empty() ? 1.0f : weights[index_[j]];
    }
}

Moments CandidateBlock::Within(const Eigen::Vector3f& p, float radius2) const {
    const Eigen::Vector3f a = p - anchor_;
    const float px = a.x(), py = a.y(), pz = a.z();
    const float* x = x_.data();
    const float* y = y_.data();
    const float* z = z_.data();
    const float* weight = w_.data();
    const auto n = static_cast<long>(x_.size());
    float count = 0.0f, total = 0.0f, sx = 0.0f, sy = 0.0f, sz = 0.0f;
    float sxx = 0.0f, sxy = 0.0f, sxz = 0.0f, syy = 0.0f, syz = 0.0f, szz = 0.0f;
    // Branch-free: each point counts inside the ball and not outside.
#pragma omp simd reduction(+ : count, total, sx, sy, sz, sxx, sxy, sxz, syy, syz, szz)
    for (long j = 0; j < n; ++j) {
        const float dx = x[j] - px, dy = y[j] - py, dz = z[j] - pz;
        const float in = static_cast<float>(dx * dx + dy * dy + dz * dz <= radius2);
        const float w = in * weight[j];
        count += in;
        total += w;
        sx += w * dx;
        sy += w * dy;
        sz += w * dz;
        sxx += w * dx * dx;
        sxy += w * dx * dy;
        sxz += w * dx * dz;
        syy += w * dy * dy;
        syz += w * dy * dz;
        szz += w * dz * dz;
    }
    Moments m;
    m.count = static_cast<int>(count);
    m.weight = static_cast<double>(total);
    m.sum = Eigen::Vector3f(sx, sy, sz).cast<double>();
    Eigen::Matrix3f outer;
    outer << sxx, sxy, sxz, sxy, syy, syz, sxz, syz, szz;
    m.outer = outer.cast<double>();
    return m;
}

void CandidateBlock::SquaredDistances(const Eigen::Vector3f& p, std::vector<float>& out) const {
    const Eigen::Vector3f a = p - anchor_;
    const float px = a.x(), py = a.y(), pz = a.z();
    const std::size_t n = x_.size();
    out.resize(n);
    const float* x = x_.data();
    const float* y = y_.data();
    const float* z = z_.data();
    float* d = out.data();
#pragma omp simd
    for (std::size_t j = 0; j < n; ++j) {
        const float dx = x[j] - px, dy = y[j] - py, dz = z[j] - pz;
        d[j] = dx * dx + dy * dy + dz * dz;
    }
}

}  // namespace soilvol::cloud
