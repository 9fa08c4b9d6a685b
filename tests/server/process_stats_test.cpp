#include "server/base/process_stats.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <string>

namespace soilvol::server {
namespace {

// A real line (Linux 6.1, fields 1-52), its name holding a space and parentheses.
const std::string kLine =
    "4242 (soil vol (x)) S 1 4242 4242 0 -1 4194560 5000 0 0 0 250 75 0 0 20 0 9 0 123456 "
    "987654321 2048 18446744073709551615 1 1 0 0 0 0 0 4096 0 0 0 0 17 1 0 0 0 0 0 0 0 0 0 0 "
    "0 0 0";

TEST(ProcessStatsTest, ReadsTheFieldsAfterTheLastParenthesis) {
    const auto stat = ParseProcStat(kLine);
    ASSERT_TRUE(stat.has_value());
    EXPECT_EQ(stat->utime_ticks, 250u);
    EXPECT_EQ(stat->stime_ticks, 75u);
    EXPECT_EQ(stat->start_ticks, 123456u);
    EXPECT_EQ(stat->vsize_bytes, 987654321u);
    EXPECT_EQ(stat->rss_pages, 2048);
}

TEST(ProcessStatsTest, RefusesLinesThatAreNotOne) {
    for (const std::string& line :
         {std::string(), std::string("4242 (name"), std::string("4242 name) S 1"),
          std::string(")( S 1 2 3"), kLine.substr(0, kLine.find(" 2048")),
          std::string("1 (a) S 1 1 1 0 -1 0 0 0 0 0 x 75 0 0 20 0 9 0 1 2 3"),
          std::string("1 (a) S 1 1 1 0 -1 0 0 0 0 0 1 75 0 0 20 0 9 0 1 2 -3"),
          std::string("1 (a) S 1 1 1 0 -1 0 0 0 0 0 99999999999999999999999 75 0 0 20 0 9 0 1 "
                      "2 3"),
          std::string(1 << 16, ')')}) {
        EXPECT_FALSE(ParseProcStat(line).has_value()) << line.substr(0, 80);
    }
}

TEST(ProcessStatsTest, ReadsBootTimeAndTheSoftFileLimit) {
    EXPECT_EQ(ParseBootTime("cpu  1 2 3\nintr 5\nbtime 1765000000\nprocesses 9\n"), 1765000000.0);
    EXPECT_FALSE(ParseBootTime("cpu 1 2\nbtime\nbtime x\n").has_value());
    EXPECT_FALSE(ParseBootTime("").has_value());
    const std::string limits =
        "Limit                     Soft Limit           Hard Limit           Units\n"
        "Max processes             95000                95000                processes\n"
        "Max open files            1024                 524288               files\n";
    EXPECT_EQ(ParseMaxOpenFiles(limits), 1024.0);
    EXPECT_FALSE(ParseMaxOpenFiles("Max open files            unlimited  unlimited files\n"));
    EXPECT_FALSE(ParseMaxOpenFiles("Max open files").has_value());
    EXPECT_FALSE(ParseMaxOpenFiles("").has_value());
}

TEST(ProcessStatsTest, ThisProcessHasPlausibleFigures) {
    const ProcessStats s = ReadProcessStats();
    const double now =
        std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
    EXPECT_GE(s.cpu_seconds, 0.0);
    EXPECT_GT(s.resident_bytes, 1 << 20);  // a test binary with its libraries
    EXPECT_GE(s.virtual_bytes, s.resident_bytes);
    EXPECT_LE(s.start_time_s, now + 1.0);  // clock ticks round the start
    EXPECT_GT(s.start_time_s, now - 3600.0);
    EXPECT_GE(s.open_fds, 3.0);  // stdin, stdout, stderr
    EXPECT_GE(s.max_fds, s.open_fds);
    EXPECT_EQ(s.max_fds, static_cast<double>(sysconf(_SC_OPEN_MAX)));
}

}  // namespace
}  // namespace soilvol::server
