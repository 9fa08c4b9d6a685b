#pragma once

#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace soilvol {

/// What a binary was built from, fixed when the build was configured (cmake/BuildInfo.cmake).
struct BuildInfo {
    std::string version;     ///< the project's semantic version, "0.14.0"
    std::string revision;    ///< `git describe --always --dirty`, "unknown" outside a checkout
    std::string build_type;  ///< Release, Debug, ...
    std::string compiler;    ///< "GNU 12.2.0"
    /// The libraries that shape results, by name: eigen, pcl, opencv, protobuf, grpc.
    std::vector<std::pair<std::string, std::string>> libraries;
};

const BuildInfo& GetBuildInfo();

/// "<program> 0.14.0 (revision v0.14.0-3-gabc1234, Release, GNU 12.2.0)": what --version prints.
std::string VersionLine(std::string_view program);

}  // namespace soilvol
