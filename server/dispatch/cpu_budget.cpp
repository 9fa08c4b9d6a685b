#include "server/dispatch/cpu_budget.hpp"

#include <sched.h>

#include <algorithm>
#include <charconv>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

namespace soilvol::server {
namespace {

std::string ReadSmallFile(const std::string& path) {
    std::ifstream in(path);
    if (!in) return {};
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
}

std::string_view Trim(std::string_view text) {
    const auto first = text.find_first_not_of(" \t\r\n");
    if (first == std::string_view::npos) return {};
    const auto last = text.find_last_not_of(" \t\r\n");
    return text.substr(first, last - first + 1);
}

bool ParseInt(std::string_view text, long long& value) {
    text = Trim(text);
    const char* end = text.data() + text.size();
    const auto [ptr, ec] = std::from_chars(text.data(), end, value);
    return ec == std::errc() && ptr == end && !text.empty();
}

int CeilCpus(long long quota, long long period) {
    if (quota <= 0 || period <= 0) return 0;
    const long long cpus = (quota + period - 1) / period;
    return static_cast<int>(std::min<long long>(cpus, 1 << 20));
}

/// The cgroup v2 path of this process ("0::/kubepods/..." in /proc/self/cgroup), or "".
std::string CgroupV2Path() {
    std::istringstream lines(ReadSmallFile("/proc/self/cgroup"));
    for (std::string line; std::getline(lines, line);) {
        if (line.rfind("0::", 0) == 0) return line.substr(3);
    }
    return {};
}

/// The tightest cpu.max from the process's cgroup up to the root of /sys/fs/cgroup; 0 = none.
int CgroupV2Limit() {
    std::string path = CgroupV2Path();
    int limit = 0;
    for (;;) {
        const int cpus = CpusFromCgroupV2(ReadSmallFile("/sys/fs/cgroup" + path + "/cpu.max"));
        if (cpus > 0) limit = limit == 0 ? cpus : std::min(limit, cpus);
        if (path.empty() || path == "/") break;
        const auto slash = path.find_last_of('/');
        path = slash == std::string::npos ? std::string() : path.substr(0, slash);
    }
    return limit;
}

int CgroupV1Limit() {
    for (const char* dir : {"/sys/fs/cgroup/cpu,cpuacct", "/sys/fs/cgroup/cpu"}) {
        const std::string base(dir);
        const int cpus = CpusFromCgroupV1(ReadSmallFile(base + "/cpu.cfs_quota_us"),
                                          ReadSmallFile(base + "/cpu.cfs_period_us"));
        if (cpus > 0) return cpus;
    }
    return 0;
}

int AffinityCpus() {
    cpu_set_t set;
    CPU_ZERO(&set);
    if (sched_getaffinity(0, sizeof(set), &set) == 0) return CPU_COUNT(&set);
    return static_cast<int>(std::thread::hardware_concurrency());
}

}  // namespace

int CpusFromCgroupV2(std::string_view cpu_max) {
    cpu_max = Trim(cpu_max);
    const auto space = cpu_max.find(' ');
    if (space == std::string_view::npos) return 0;
    long long quota = 0;
    long long period = 0;
    if (!ParseInt(cpu_max.substr(0, space), quota)) return 0;  // "max": no limit
    if (!ParseInt(cpu_max.substr(space + 1), period)) return 0;
    return CeilCpus(quota, period);
}

int CpusFromCgroupV1(std::string_view quota_us, std::string_view period_us) {
    long long quota = 0;
    long long period = 0;
    if (!ParseInt(quota_us, quota) || !ParseInt(period_us, period)) return 0;
    return CeilCpus(quota, period);  // quota -1 = no limit
}

int AvailableCpus() {
    int cpus = std::max(1, AffinityCpus());
    for (const int limit : {CgroupV2Limit(), CgroupV1Limit()}) {
        if (limit > 0) cpus = std::min(cpus, limit);
    }
    return cpus;
}

int ThreadsPerCall(int cpus, int workers) {
    cpus = std::max(1, cpus);
    workers = std::max(1, workers);
    return std::min(cpus, (2 * cpus + workers - 1) / workers);
}

}  // namespace soilvol::server
