#include "server/handlers/stored_record.hpp"

#include <gtest/gtest.h>

#include <random>

#include "soilvol/v1/soilvol.pb.h"

namespace soilvol::server {
namespace {

v1::Container Info() {
    v1::Container info;
    info.set_container_id("bucket-7");
    info.set_struck_capacity_m3(0.664);
    info.set_max_range_m(6.0);
    return info;
}

TEST(StoredRecord, RoundTripsInfoAndBody) {
    const std::string body("model\0bytes", 11);
    const std::string payload = EncodeStoredRecord(Info(), body);
    v1::Container info;
    std::string_view got;
    ASSERT_TRUE(DecodeStoredRecord(payload, &info, &got).ok());
    EXPECT_EQ(info.container_id(), "bucket-7");
    EXPECT_TRUE(info.has_max_range_m());
    EXPECT_EQ(got, body);
}

TEST(StoredRecord, EveryTruncationIsDataLossOrAShorterBody) {
    const std::string payload = EncodeStoredRecord(Info(), "body");
    const std::size_t info_end = payload.size() - 4;
    for (std::size_t n = 0; n < payload.size(); ++n) {
        v1::Container info;
        std::string_view body;
        const absl::Status status = DecodeStoredRecord(payload.substr(0, n), &info, &body);
        if (n < info_end) {
            EXPECT_TRUE(absl::IsDataLoss(status)) << n;
        } else {
            EXPECT_TRUE(status.ok())
                << n;  // the body has no framing: the entry file's checksum guards it
            EXPECT_EQ(body.size(), n - info_end);
        }
    }
}

TEST(StoredRecord, HostileHeadersNeverCrash) {
    std::mt19937_64 rng(7);
    for (int trial = 0; trial < 2000; ++trial) {
        std::string payload(static_cast<std::size_t>(rng() % 64), '\0');
        for (char& c : payload) c = static_cast<char>(rng());
        v1::Container info;
        std::string_view body;
        const absl::Status status = DecodeStoredRecord(payload, &info, &body);
        EXPECT_TRUE(status.ok() || absl::IsDataLoss(status));
    }
    v1::Container info;
    std::string_view body;
    EXPECT_TRUE(
        absl::IsDataLoss(DecodeStoredRecord(std::string("\xff\xff\xff\xff", 4), &info, &body)));
}

}  // namespace
}  // namespace soilvol::server
