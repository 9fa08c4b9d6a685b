#include "server/base/status_map.hpp"

#include <gtest/gtest.h>

#include "google/rpc/error_details.pb.h"
#include "google/rpc/status.pb.h"

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

TEST(StatusMap, ErrorJsonIsAGoogleRpcStatusWithErrorInfo) {
    EXPECT_EQ(ErrorJson(absl::NotFoundError("container_id: 'a' not found")),
              R"({"code":5,"message":"container_id: 'a' not found","details":[)"
              R"({"@type":"type.googleapis.com/google.rpc.ErrorInfo","reason":"NOT_FOUND",)"
              R"("domain":"soilvol","metadata":{"field":"container_id"}}]})");
}

google::rpc::Status Parsed(const absl::Status& status) {
    google::rpc::Status out;
    EXPECT_TRUE(out.ParseFromString(RpcStatusBytes(status)));
    return out;
}

TEST(StatusMap, InvalidArgumentNamesTheFieldInABadRequest) {
    const google::rpc::Status s =
        Parsed(absl::InvalidArgumentError("additional_scans[1].opening: needs 4 corners"));
    EXPECT_EQ(s.code(), 3);
    ASSERT_EQ(s.details_size(), 2);
    google::rpc::BadRequest bad;
    ASSERT_TRUE(s.details(1).UnpackTo(&bad));
    ASSERT_EQ(bad.field_violations_size(), 1);
    EXPECT_EQ(bad.field_violations(0).field(), "additional_scans[1].opening");
    EXPECT_EQ(bad.field_violations(0).description(), "needs 4 corners");
}

TEST(StatusMap, ExhaustedAndUnavailableCarryRetryInfoAndOthersDoNot) {
    for (const auto& status :
         {absl::ResourceExhaustedError("queue full"), absl::UnavailableError("shutting down")}) {
        const google::rpc::Status s = Parsed(status);
        google::rpc::RetryInfo retry;
        ASSERT_EQ(s.details_size(), 2);
        ASSERT_TRUE(s.details(1).UnpackTo(&retry));
        EXPECT_EQ(retry.retry_delay().seconds(), 1);
        EXPECT_EQ(RetryAfterSeconds(status), 1);
    }
    EXPECT_EQ(Parsed(absl::FailedPreconditionError("x")).details_size(), 1);
    EXPECT_EQ(RetryAfterSeconds(absl::InvalidArgumentError("x")), 0);
    const absl::Status too_large =
        WithReason(absl::ResourceExhaustedError("body: too large"), kReasonTooLarge);
    EXPECT_EQ(RetryAfterSeconds(too_large), 0);
    EXPECT_EQ(Parsed(too_large).details_size(), 1);
    EXPECT_TRUE(RpcStatusBytes(absl::OkStatus()).empty());
}

TEST(StatusMap, ReasonOverridesTheCodeName) {
    google::rpc::ErrorInfo info;
    ASSERT_TRUE(Parsed(WithReason(absl::AbortedError("etag: stale"), "ETAG_MISMATCH"))
                    .details(0)
                    .UnpackTo(&info));
    EXPECT_EQ(info.reason(), "ETAG_MISMATCH");
    EXPECT_EQ(info.domain(), "soilvol");
    EXPECT_EQ(info.metadata().at("field"), "etag");
}

TEST(StatusMap, FieldOfTakesOnlyFieldPaths) {
    EXPECT_EQ(FieldOf("scan.cloud.data: truncated"), "scan.cloud.data");
    EXPECT_EQ(FieldOf("chessboard.pairs[3]: needs both"), "chessboard.pairs[3]");
    EXPECT_EQ(FieldOf("Content-Type: must be json"), "");
    EXPECT_EQ(FieldOf("container 'a' not found"), "");
    EXPECT_EQ(FieldOf("a..b: x"), "");
    EXPECT_EQ(FieldOf("pairs[]: x"), "");
    EXPECT_EQ(FieldOf("pairs[1x]: x"), "");
    EXPECT_EQ(FieldOf(": x"), "");
}

TEST(StatusMap, MessagesArePrintableAscii) {
    EXPECT_EQ(SafeMessage("a\n\xff\xc3\xa9"
                          "b"),
              "a\\x0a\\xff\\xc3\\xa9b");
    EXPECT_EQ(Parsed(absl::InternalError("\x01")).message(), "\\x01");
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
