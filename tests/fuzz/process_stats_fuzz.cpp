// libFuzzer: the /proc readers behind the process_* metrics (server/base/process_stats) on any
// bytes: a line they accept has its fields as numbers, and none reads past its input.
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "server/base/process_stats.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    if (const auto stat = soilvol::server::ParseProcStat(text)) {
        if (stat->rss_pages < 0 || text.find(')') == std::string_view::npos) std::abort();
    }
    if (const auto boot = soilvol::server::ParseBootTime(text); boot && !(*boot >= 0.0)) {
        std::abort();
    }
    if (const auto most = soilvol::server::ParseMaxOpenFiles(text); most && !(*most >= 0.0)) {
        std::abort();
    }
    return 0;
}
