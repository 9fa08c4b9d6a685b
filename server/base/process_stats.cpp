#include "server/base/process_stats.hpp"

#include <dirent.h>
#include <unistd.h>

#include <charconv>
#include <optional>
#include <string>
#include <vector>

#include "server/base/watched_file.hpp"

namespace soilvol::server {
namespace {

// The whitespace-separated words of `text`.
std::vector<std::string_view> Words(std::string_view text) {
    std::vector<std::string_view> words;
    std::size_t i = 0;
    while (i < text.size()) {
        while (i < text.size() && (text[i] == ' ' || text[i] == '\t' || text[i] == '\n')) ++i;
        const std::size_t start = i;
        while (i < text.size() && text[i] != ' ' && text[i] != '\t' && text[i] != '\n') ++i;
        if (i > start) words.push_back(text.substr(start, i - start));
    }
    return words;
}

template <typename T>
bool ParseNumber(std::string_view word, T& out) {
    const auto [end, error] = std::from_chars(word.data(), word.data() + word.size(), out);
    return error == std::errc() && end == word.data() + word.size();
}

// A /proc file's text, "" when it cannot be read whole within `max_bytes`.
std::string ProcText(const std::string& path, std::size_t max_bytes) {
    return ReadSmallFile(path, max_bytes, "metrics").value_or("");
}

double OpenFds() {
    DIR* dir = opendir("/proc/self/fd");
    if (dir == nullptr) return 0.0;
    double count = 0.0;
    while (const dirent* entry = readdir(dir)) {
        if (entry->d_name[0] != '.') count += 1.0;
    }
    closedir(dir);
    return count - 1.0;  // the directory's own descriptor
}

}  // namespace

std::optional<ProcStat> ParseProcStat(std::string_view line) {
    const std::size_t close = line.rfind(')');
    if (close == std::string_view::npos || line.find('(') > close) return std::nullopt;
    // After the name: state (field 3) is the first word; utime is field 14, stime 15,
    // starttime 22, vsize 23, rss 24.
    const std::vector<std::string_view> w = Words(line.substr(close + 1));
    constexpr std::size_t kFirst = 3;
    if (w.size() < 24 - kFirst + 1) return std::nullopt;
    ProcStat stat;
    const bool ok = ParseNumber(w[14 - kFirst], stat.utime_ticks) &&
                    ParseNumber(w[15 - kFirst], stat.stime_ticks) &&
                    ParseNumber(w[22 - kFirst], stat.start_ticks) &&
                    ParseNumber(w[23 - kFirst], stat.vsize_bytes) &&
                    ParseNumber(w[24 - kFirst], stat.rss_pages);
    if (!ok || stat.rss_pages < 0) return std::nullopt;
    return stat;
}

std::optional<double> ParseBootTime(std::string_view proc_stat) {
    std::size_t at = 0;
    while (at < proc_stat.size()) {
        std::size_t end = proc_stat.find('\n', at);
        if (end == std::string_view::npos) end = proc_stat.size();
        const std::vector<std::string_view> w = Words(proc_stat.substr(at, end - at));
        unsigned long long seconds = 0;
        if (w.size() == 2 && w[0] == "btime" && ParseNumber(w[1], seconds)) {
            return static_cast<double>(seconds);
        }
        at = end + 1;
    }
    return std::nullopt;
}

std::optional<double> ParseMaxOpenFiles(std::string_view limits) {
    constexpr std::string_view kName = "Max open files";
    const std::size_t at = limits.find(kName);
    if (at == std::string_view::npos) return std::nullopt;
    std::size_t end = limits.find('\n', at);
    if (end == std::string_view::npos) end = limits.size();
    const std::vector<std::string_view> w =
        Words(limits.substr(at + kName.size(), end - at - kName.size()));
    unsigned long long soft = 0;
    if (w.empty() || !ParseNumber(w[0], soft)) return std::nullopt;
    return static_cast<double>(soft);
}

ProcessStats ReadProcessStats() {
    ProcessStats out;
    const double ticks = static_cast<double>(sysconf(_SC_CLK_TCK));
    const double page = static_cast<double>(sysconf(_SC_PAGESIZE));
    if (const auto stat = ParseProcStat(ProcText("/proc/self/stat", 4096)); stat && ticks > 0) {
        out.cpu_seconds = static_cast<double>(stat->utime_ticks + stat->stime_ticks) / ticks;
        out.resident_bytes = static_cast<double>(stat->rss_pages) * page;
        out.virtual_bytes = static_cast<double>(stat->vsize_bytes);
        // The boot time does not change: /proc/stat (per-CPU lines and interrupt counts before
        // btime, up to 1 MiB on large machines) is read at the first scrape only.
        static const std::optional<double> boot = ParseBootTime(ProcText("/proc/stat", 1 << 20));
        if (boot) out.start_time_s = *boot + static_cast<double>(stat->start_ticks) / ticks;
    }
    out.open_fds = OpenFds();
    out.max_fds = ParseMaxOpenFiles(ProcText("/proc/self/limits", 1 << 16)).value_or(0.0);
    return out;
}

}  // namespace soilvol::server
