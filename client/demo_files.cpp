#include "client/demo_files.hpp"

#include <google/protobuf/util/json_util.h>

#include <filesystem>
#include <fstream>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"

namespace soilvol::client {
namespace {

absl::Status WriteFile(const std::string& dir, const std::string& name,
                       const std::string& content) {
    std::error_code error;
    std::filesystem::create_directories(dir, error);
    const std::string path = (std::filesystem::path(dir) / name).string();
    std::ofstream file(path, std::ios::binary);
    file.write(content.data(), static_cast<std::streamsize>(content.size()));
    file.close();
    if (!file) return absl::InternalError(absl::StrCat("cannot write '", path, "'"));
    return absl::OkStatus();
}

std::string CornersArgument(const v1::Opening& opening) {
    std::vector<std::string> points;
    for (const v1::Point3& p : opening.corners()) {
        points.push_back(absl::StrFormat("%.6f,%.6f,%.6f", p.x(), p.y(), p.z()));
    }
    for (const v1::PixelPoint& p : opening.pixel_corners()) {
        points.push_back(absl::StrFormat("%.3f,%.3f", p.u(), p.v()));
    }
    return absl::StrJoin(points, ";") + "\n";
}

/// "x,y,z;qw,qx,qy,qz", as --container-pose takes it.
std::string PoseArgument(const v1::Pose& pose) {
    const v1::Point3& p = pose.position_m();
    const v1::Quaternion& q = pose.orientation();
    return absl::StrFormat("%.6f,%.6f,%.6f;%.9f,%.9f,%.9f,%.9f\n", p.x(), p.y(), p.z(), q.w(),
                           q.x(), q.y(), q.z());
}

}  // namespace

absl::Status SaveDemoScan(const std::string& dir, const std::string& stem, const DemoScan& scan) {
    absl::Status status = WriteFile(dir, stem + "-corners.txt", CornersArgument(scan.opening));
    if (scan.scan.has_cloud()) {
        status.Update(WriteFile(dir, stem + ".ply", scan.scan.cloud().data()));
        status.Update(WriteFile(dir, stem + "-pose.txt", PoseArgument(scan.container_pose)));
    } else if (scan.scan.has_depth()) {
        const v1::DepthCamera& k = scan.scan.depth().camera();
        status.Update(WriteFile(dir, stem + ".png", scan.scan.depth().depth()));
        status.Update(WriteFile(dir, stem + "-pose.txt", PoseArgument(scan.container_pose)));
        // The camera as the CLI's --intrinsics and as a REST query.
        status.Update(WriteFile(
            dir, "intrinsics.txt",
            absl::StrFormat("%.17g,%.17g,%.17g,%.17g\n", k.fx(), k.fy(), k.cx(), k.cy())));
        status.Update(WriteFile(dir, "camera-query.txt",
                                absl::StrFormat("scan.depth.camera.fx=%.17g&scan.depth.camera.fy="
                                                "%.17g&scan.depth.camera.cx=%.17g&scan.depth."
                                                "camera.cy=%.17g\n",
                                                k.fx(), k.fy(), k.cx(), k.cy())));
    } else {
        status.Update(WriteFile(dir, stem + "-left.png", scan.scan.stereo().left()));
        status.Update(WriteFile(dir, stem + "-right.png", scan.scan.stereo().right()));
    }
    return status;
}

absl::Status SaveDemoMesh(const std::string& dir, const DemoMesh& mesh, const v1::Pose& pose,
                          double range_noise_m) {
    absl::Status status = WriteFile(dir, "mesh.stl", mesh.stl);
    status.Update(WriteFile(dir, "mesh-corners.txt", CornersArgument(mesh.opening)));
    v1::MeshScan placement;
    *placement.mutable_corners() = mesh.opening.corners();
    *placement.mutable_container_pose() = pose;
    placement.set_range_noise_m(range_noise_m);
    std::string json;
    if (!google::protobuf::util::MessageToJsonString(placement, &json).ok()) {
        return absl::InternalError("cannot print the mesh's placement as JSON");
    }
    status.Update(WriteFile(dir, "mesh.json", json + "\n"));
    return status;
}

absl::Status SaveDemoParameters(const std::string& dir, const v1::StereoParameters& parameters) {
    google::protobuf::util::JsonPrintOptions options;
    options.add_whitespace = true;
    std::string json;
    if (!google::protobuf::util::MessageToJsonString(parameters, &json, options).ok()) {
        return absl::InternalError("cannot print the rig parameters as JSON");
    }
    return WriteFile(dir, "parameters.json", json);
}

}  // namespace soilvol::client
