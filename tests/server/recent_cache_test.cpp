#include "server/base/recent_cache.hpp"

#include <gtest/gtest.h>

#include <string>

namespace soilvol::server {
namespace {

TEST(RecentCacheTest, KeysCycledWithinItsSizeAreMadeOnce) {
    // A feed's group of rows, to one watch after another: each row made once.
    RecentCache<int, std::string, 4> cache;
    int made = 0;
    const auto make = [&made](int key, std::string& value) {
        ++made;
        value = "row " + std::to_string(key);
    };
    for (int watch = 0; watch < 100; ++watch) {
        for (int row = 10; row < 14; ++row)
            EXPECT_EQ(cache.Get(row, make), "row " + std::to_string(row));
    }
    EXPECT_EQ(made, 4);
}

TEST(RecentCacheTest, TheOldestIsReplacedAndTheRestStayWhereTheyWere) {
    RecentCache<int, std::string, 3> cache;
    int made = 0;
    const auto make = [&made](int key, std::string& value) {
        ++made;
        value = std::to_string(key);
    };
    const std::string* two = &cache.Get(2, make);
    cache.Get(1, make);
    cache.Get(3, make);
    cache.Get(4, make);  // replaces 2, the oldest made
    EXPECT_EQ(made, 4);
    EXPECT_EQ(&cache.Get(4, make), two);  // the slot 2 had
    EXPECT_EQ(*two, "4");
    EXPECT_EQ(cache.Get(1, make), "1");
    EXPECT_EQ(made, 4);
    EXPECT_EQ(cache.Get(2, make), "2");  // made again, in place of 1
    EXPECT_EQ(made, 5);
    EXPECT_EQ(cache.Get(3, make), "3");
    EXPECT_EQ(made, 5);
}

}  // namespace
}  // namespace soilvol::server
