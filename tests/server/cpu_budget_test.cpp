#include "server/dispatch/cpu_budget.hpp"

#include <gtest/gtest.h>
#include <sched.h>

namespace soilvol::server {
namespace {

TEST(CpuBudget, CgroupV2QuotaRoundsUp) {
    EXPECT_EQ(CpusFromCgroupV2("200000 100000\n"), 2);
    EXPECT_EQ(CpusFromCgroupV2("150000 100000"), 2);  // 1.5 CPUs: two threads may run
    EXPECT_EQ(CpusFromCgroupV2("50000 100000"), 1);
    EXPECT_EQ(CpusFromCgroupV2("  400000   100000  "), 4);  // extra spaces are tolerated
}

TEST(CpuBudget, CgroupV2WithoutALimitOrUnreadableIsZero) {
    for (const char* text : {"max 100000", "", "\n", "200000", "abc 100000", "200000 abc",
                             "-200000 100000", "200000 0", "200000 -1", "2e5 100000",
                             "99999999999999999999999 100000", "200000 100000 7"}) {
        EXPECT_EQ(CpusFromCgroupV2(text), 0) << "'" << text << "'";
    }
}

TEST(CpuBudget, CgroupV1) {
    EXPECT_EQ(CpusFromCgroupV1("300000\n", "100000\n"), 3);
    EXPECT_EQ(CpusFromCgroupV1("-1\n", "100000\n"), 0);  // no limit
    EXPECT_EQ(CpusFromCgroupV1("", ""), 0);              // no such files
    EXPECT_EQ(CpusFromCgroupV1("100000", "x"), 0);
    EXPECT_EQ(CpusFromCgroupV1("100000", "0"), 0);
}

TEST(CpuBudget, AvailableCpusIsWithinTheAffinityMask) {
    cpu_set_t set;
    CPU_ZERO(&set);
    ASSERT_EQ(sched_getaffinity(0, sizeof(set), &set), 0);
    const int cpus = AvailableCpus();
    EXPECT_GE(cpus, 1);
    EXPECT_LE(cpus, CPU_COUNT(&set));
}

TEST(CpuBudget, ThreadsPerCallSharesTheCpus) {
    EXPECT_EQ(ThreadsPerCall(8, 1), 8);  // one call at a time gets every CPU, no more
    EXPECT_EQ(ThreadsPerCall(8, 2), 8);
    EXPECT_EQ(ThreadsPerCall(8, 3), 6);    // 3 x 6 = 18 threads: at most 2 per CPU, rounded up
    EXPECT_EQ(ThreadsPerCall(16, 16), 2);  // one worker per CPU: two threads each
    EXPECT_EQ(ThreadsPerCall(2, 2), 2);
    EXPECT_EQ(ThreadsPerCall(2, 8), 1);  // more workers than CPUs: one thread each
    EXPECT_EQ(ThreadsPerCall(4, 0), 4);
    EXPECT_EQ(ThreadsPerCall(0, 3), 1);
}

}  // namespace
}  // namespace soilvol::server
