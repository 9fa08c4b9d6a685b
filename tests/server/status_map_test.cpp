#include "server/status_map.hpp"

#include <gtest/gtest.h>

namespace soilvol::server {
namespace {

TEST(StatusMap, HttpStatusFollowsTheGrpcGatewayMapping) {
    const std::pair<absl::StatusCode, int> expected[] = {
        {absl::StatusCode::kOk, 200},
        {absl::StatusCode::kInvalidArgument, 400},
        {absl::StatusCode::kFailedPrecondition, 400},
        {absl::StatusCode::kOutOfRange, 400},
        {absl::StatusCode::kUnauthenticated, 401},
        {absl::StatusCode::kPermissionDenied, 403},
        {absl::StatusCode::kNotFound, 404},
        {absl::StatusCode::kAlreadyExists, 409},
        {absl::StatusCode::kAborted, 409},
        {absl::StatusCode::kResourceExhausted, 429},
        {absl::StatusCode::kCancelled, 499},
        {absl::StatusCode::kUnknown, 500},
        {absl::StatusCode::kInternal, 500},
        {absl::StatusCode::kDataLoss, 500},
        {absl::StatusCode::kUnimplemented, 501},
        {absl::StatusCode::kUnavailable, 503},
        {absl::StatusCode::kDeadlineExceeded, 504},
    };
    for (const auto& [code, http] : expected)
        EXPECT_EQ(HttpStatusFor(code), http) << CodeName(code);
}

TEST(StatusMap, ErrorJsonHasCodeMessageAndDetails) {
    EXPECT_EQ(ErrorJson(absl::NotFoundError("container 'a' not found")),
              R"({"code":5,"message":"container 'a' not found","details":[]})");
}

TEST(StatusMap, ErrorJsonEscapesEverythingThatIsNotPrintableAscii) {
    const std::string message = "q\"b\\n\n\t\x01\xff\xc3\xa9";
    EXPECT_EQ(JsonQuote(message), R"("q\"b\\n\n\t\u0001\u00ff\u00c3\u00a9")");
}

TEST(StatusMap, AnnotatePrefixesTheFieldAndKeepsTheCode) {
    const absl::Status s = Annotate(absl::InvalidArgumentError("bad"), "scan.cloud.data");
    EXPECT_TRUE(absl::IsInvalidArgument(s));
    EXPECT_EQ(s.message(), "scan.cloud.data: bad");
    EXPECT_TRUE(Annotate(absl::OkStatus(), "x").ok());
}

}  // namespace
}  // namespace soilvol::server
