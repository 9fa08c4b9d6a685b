#pragma once

#include <string_view>
#include <vector>

namespace soilvol::server {

/// One file of the dashboard (server/dashboard), built into the binary.
struct DashboardFile {
    std::string_view name;  ///< "index.html", "app.js"
    std::string_view content_type;
    std::string_view body;
};

/// Every dashboard file, by name.
const std::vector<DashboardFile>& DashboardFiles();

}  // namespace soilvol::server
