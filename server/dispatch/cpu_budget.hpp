#pragma once

// How many CPUs the server may use, and how many threads one call gets. In a container,
// std::thread::hardware_concurrency() counts the node's cores, not the CPU limit: a pod limited
// to 2 CPUs on a 64-core node would start 64 workers, each running 64-thread OpenMP loops.

#include <string_view>

namespace soilvol::server {

/// CPUs this process may run on: the affinity mask, capped by the cgroup CPU quota (cgroup v2
/// cpu.max of the process's cgroup and its parents, or v1 cpu.cfs_quota_us / cfs_period_us),
/// rounded up; at least 1.
int AvailableCpus();

/// CPUs a cgroup v2 `cpu.max` file allows ("200000 100000" -> 2, "150000 100000" -> 2);
/// 0 for "max" (no limit) or text it cannot read.
int CpusFromCgroupV2(std::string_view cpu_max);

/// The same for cgroup v1 files cpu.cfs_quota_us ("-1" = no limit) and cpu.cfs_period_us.
int CpusFromCgroupV1(std::string_view quota_us, std::string_view period_us);

/// Threads one call may use when `workers` calls run at once on `cpus` CPUs: 2 x cpus / workers
/// rounded up, at most cpus. A busy server runs at most two engine threads per CPU (on 2 cores
/// that costs no throughput against one per CPU and keeps a lone call 1.5x faster), and never
/// a thread per core of a node whose CPUs the container may not use.
int ThreadsPerCall(int cpus, int workers);

}  // namespace soilvol::server
