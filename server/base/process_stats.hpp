#pragma once

#include <optional>
#include <string_view>

namespace soilvol::server {

/// What Prometheus's process_* metrics report (the names every exporter and dashboard knows),
/// read from Linux's /proc.
struct ProcessStats {
    double cpu_seconds = 0.0;  ///< user + system time
    double resident_bytes = 0.0;
    double virtual_bytes = 0.0;
    double start_time_s = 0.0;  ///< since the Unix epoch
    double open_fds = 0.0;
    double max_fds = 0.0;  ///< the soft limit
};

/// The fields of /proc/self/stat's one line that ProcessStats needs, in the kernel's units:
/// clock ticks (utime, stime, starttime since boot), bytes (vsize) and pages (rss). None when
/// the line is not one: the command name in parentheses may hold spaces and parentheses, so the
/// fields are counted from the last ')'.
struct ProcStat {
    unsigned long long utime_ticks = 0, stime_ticks = 0, start_ticks = 0;
    unsigned long long vsize_bytes = 0;
    long long rss_pages = 0;
};
std::optional<ProcStat> ParseProcStat(std::string_view line);

/// "btime" of /proc/stat: the boot time, seconds since the epoch; none without it.
std::optional<double> ParseBootTime(std::string_view proc_stat);

/// The soft "Max open files" of /proc/self/limits; none without it ("unlimited": none).
std::optional<double> ParseMaxOpenFiles(std::string_view limits);

/// This process's figures now; fields that cannot be read stay 0.
ProcessStats ReadProcessStats();

}  // namespace soilvol::server
