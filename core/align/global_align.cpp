#include "core/align/global_align.hpp"

#include <omp.h>
#include <pcl/features/fpfh_omp.h>
#include <pcl/features/normal_3d_omp.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/registration/sample_consensus_prerejective.h>
#include <pcl/search/kdtree.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "core/cloud/voxel_grid.hpp"

namespace soilvol::align {
namespace {

using PointCloud = pcl::PointCloud<pcl::PointNormal>;
using Features = pcl::PointCloud<pcl::FPFHSignature33>;

// Voxel means with normals facing `sensor`; points whose neighbourhood gives no normal are
// dropped.
PointCloud::Ptr WithNormals(const Cloud& points, const Eigen::Vector3d& sensor,
                            const GlobalAlignConfig& config, int threads) {
    const Cloud voxels = cloud::VoxelDownsample(points, config.voxel_m);
    auto xyz = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
    xyz->reserve(voxels.size());
    for (const auto& p : voxels) xyz->emplace_back(p.x(), p.y(), p.z());
    pcl::NormalEstimationOMP<pcl::PointXYZ, pcl::Normal> estimator(threads);
    estimator.setInputCloud(xyz);
    estimator.setRadiusSearch(config.normal_radius_m);
    estimator.setViewPoint(static_cast<float>(sensor.x()), static_cast<float>(sensor.y()),
                           static_cast<float>(sensor.z()));
    pcl::PointCloud<pcl::Normal> normals;
    estimator.compute(normals);
    auto out = std::make_shared<PointCloud>();
    out->reserve(xyz->size());
    for (std::size_t i = 0; i < xyz->size(); ++i) {
        const pcl::Normal& n = normals[i];
        if (!std::isfinite(n.normal_x) || !std::isfinite(n.normal_y) ||
            !std::isfinite(n.normal_z)) {
            continue;
        }
        pcl::PointNormal p;
        p.x = (*xyz)[i].x, p.y = (*xyz)[i].y, p.z = (*xyz)[i].z;
        p.normal_x = n.normal_x, p.normal_y = n.normal_y, p.normal_z = n.normal_z;
        out->push_back(p);
    }
    return out;
}

Features::Ptr Describe(const PointCloud::Ptr& cloud, const GlobalAlignConfig& config, int threads) {
    pcl::FPFHEstimationOMP<pcl::PointNormal, pcl::PointNormal, pcl::FPFHSignature33> fpfh(threads);
    fpfh.setInputCloud(cloud);
    fpfh.setInputNormals(cloud);
    fpfh.setRadiusSearch(config.feature_radius_m);
    auto features = std::make_shared<Features>();
    fpfh.compute(*features);
    return features;
}

}  // namespace

std::optional<Pose> GlobalAlign(const Cloud& source, const Eigen::Vector3d& source_sensor,
                                const Cloud& scan, const GlobalAlignConfig& config,
                                const std::optional<Pose>& reference, const StopToken& stop) {
    const int threads = config.num_threads > 0 ? config.num_threads : omp_get_max_threads();
    const PointCloud::Ptr src = WithNormals(source, source_sensor, config, threads);
    if (stop.StopRequested()) return std::nullopt;
    const PointCloud::Ptr dst = WithNormals(scan, Eigen::Vector3d::Zero(), config, threads);
    if (src->size() < 10 || dst->size() < 10 || stop.StopRequested()) return std::nullopt;
    const Features::Ptr src_features = Describe(src, config, threads);
    if (stop.StopRequested()) return std::nullopt;
    const Features::Ptr dst_features = Describe(dst, config, threads);
    pcl::SampleConsensusPrerejective<pcl::PointNormal, pcl::PointNormal, pcl::FPFHSignature33>
        ransac;
    ransac.setInputSource(src);
    ransac.setSourceFeatures(src_features);
    ransac.setInputTarget(dst);
    ransac.setTargetFeatures(dst_features);
    ransac.setMaximumIterations(config.max_iterations);
    ransac.setNumberOfSamples(3);
    ransac.setCorrespondenceRandomness(5);
    ransac.setSimilarityThreshold(0.9f);
    ransac.setMaxCorrespondenceDistance(config.inlier_distance_m);
    ransac.setInlierFraction(static_cast<float>(config.min_inlier_fraction));
    for (int attempt = 0; attempt < std::max(config.attempts, 1); ++attempt) {
        if (stop.StopRequested()) return std::nullopt;
        PointCloud aligned;
        ransac.align(aligned);
        if (!ransac.hasConverged()) continue;
        Pose pose = Pose::Identity();
        pose.matrix() = ransac.getFinalTransformation().cast<double>();
        const double turn_deg =
            reference ? Eigen::AngleAxisd((reference->inverse() * pose).linear()).angle() * 180.0 /
                            3.14159265358979
                      : 0.0;
        if (turn_deg <= config.max_turn_deg) return pose;
    }
    return std::nullopt;
}

}  // namespace soilvol::align
