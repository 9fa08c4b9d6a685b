#include "server/base/call_ids.hpp"

#include <gtest/gtest.h>

#include <string>

namespace soilvol::server {
namespace {

TEST(CallIds, ValidRequestIdsAreKept) {
    EXPECT_EQ(RequestIdOf("f81d4fae-7dec-11d0-a765-00a0c91e6bf6"),
              "f81d4fae-7dec-11d0-a765-00a0c91e6bf6");
    EXPECT_EQ(RequestIdOf("job/17:a.b_c+d="), "job/17:a.b_c+d=");
    EXPECT_EQ(RequestIdOf(std::string(128, 'a')), std::string(128, 'a'));
}

TEST(CallIds, MissingOrUnsafeRequestIdsAreReplaced) {
    for (const std::string& sent :
         {std::string(), std::string(129, 'a'), std::string("a b"), std::string("a\nb"),
          std::string("a\"b"), std::string("\xc3\xa9")}) {
        const std::string id = RequestIdOf(sent);
        EXPECT_NE(id, sent);
        EXPECT_EQ(id.size(), 32u);
        EXPECT_EQ(id.find_first_not_of("0123456789abcdef"), std::string::npos);
    }
    EXPECT_NE(RequestIdOf(""), RequestIdOf(""));
}

TEST(CallIds, TraceIdOfAW3cTraceparent) {
    EXPECT_EQ(TraceIdOf("00-4bf92f3577b34da6a3ce929d0e0e4736-00f067aa0ba902b7-01"),
              "4bf92f3577b34da6a3ce929d0e0e4736");
    // A future version may append fields.
    EXPECT_EQ(TraceIdOf("01-4bf92f3577b34da6a3ce929d0e0e4736-00f067aa0ba902b7-01-extra"),
              "4bf92f3577b34da6a3ce929d0e0e4736");
}

TEST(CallIds, MalformedTraceparentsGiveNoTraceId) {
    for (const char* bad : {
             "",
             "00-4bf92f3577b34da6a3ce929d0e0e4736-00f067aa0ba902b7",
             "00-4BF92F3577B34DA6A3CE929D0E0E4736-00f067aa0ba902b7-01",    // upper case
             "00-00000000000000000000000000000000-00f067aa0ba902b7-01",    // zero trace
             "00-4bf92f3577b34da6a3ce929d0e0e4736-0000000000000000-01",    // zero parent
             "ff-4bf92f3577b34da6a3ce929d0e0e4736-00f067aa0ba902b7-01",    // invalid version
             "00-4bf92f3577b34da6a3ce929d0e0e4736-00f067aa0ba902b7-01-x",  // 00 has no more
             "00_4bf92f3577b34da6a3ce929d0e0e4736_00f067aa0ba902b7_01",
             "00-4bf92f3577b34da6a3ce929d0e0e473g-00f067aa0ba902b7-01",
         }) {
        EXPECT_EQ(TraceIdOf(bad), "") << bad;
    }
}

}  // namespace
}  // namespace soilvol::server
