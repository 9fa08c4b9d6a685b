#include "server/webhooks/webhook_signature.hpp"

#include <gtest/gtest.h>

#include <cctype>
#include <cstdint>
#include <limits>
#include <string>

namespace soilvol::server {
namespace {

// python3 -c 'import hmac,hashlib;print(hmac.new(b"secret",b"1700000000.{\"a\":1}",
//             hashlib.sha256).hexdigest())'
constexpr const char* kKnownMac =
    "49f24e537407743fa4a0242bb63b94b9a47ee99cbbe071ccd8a22550ae411686";
constexpr std::int64_t kStamp = 1700000000;
constexpr const char* kBody = R"({"a":1})";

TEST(WebhookSignature, HeaderMatchesAnIndependentlyComputedHmac) {
    EXPECT_EQ(SignatureHeader("secret", kStamp, kBody),
              std::string("t=1700000000,v1=") + kKnownMac);
}

TEST(WebhookSignature, HeaderVariesWithSecretTimeAndBody) {
    const std::string header = SignatureHeader("secret", kStamp, kBody);
    EXPECT_NE(SignatureHeader("secret2", kStamp, kBody), header);
    EXPECT_NE(SignatureHeader("secret", kStamp + 1, kBody).substr(16), header.substr(16));
    EXPECT_NE(SignatureHeader("secret", kStamp, R"({"a":2})"), header);
    // An empty secret or body is still a well-formed 64-digit signature.
    EXPECT_EQ(SignatureHeader("", kStamp, "").size(), header.size());
}

TEST(WebhookSignature, OwnHeaderVerifiesWithinTheTolerance) {
    const std::string header = SignatureHeader("secret", kStamp, kBody);
    EXPECT_TRUE(VerifySignature(header, "secret", kBody, kStamp, 0));
    EXPECT_TRUE(VerifySignature(header, "secret", kBody, kStamp + 300, 300));
    EXPECT_TRUE(VerifySignature(header, "secret", kBody, kStamp - 300, 300));
    EXPECT_FALSE(VerifySignature(header, "secret", kBody, kStamp + 301, 300));
    EXPECT_FALSE(VerifySignature(header, "secret", kBody, kStamp - 301, 300));
    EXPECT_FALSE(VerifySignature(header, "secret", kBody, kStamp, -1));
}

TEST(WebhookSignature, AnotherSecretBodyOrTimeFailsVerification) {
    const std::string header = SignatureHeader("secret", kStamp, kBody);
    EXPECT_FALSE(VerifySignature(header, "secret2", kBody, kStamp, 300));
    EXPECT_FALSE(VerifySignature(header, "secret", R"({"a":2})", kStamp, 300));
    // The time is signed: moving t to the present breaks the signature.
    const std::string moved = std::string("t=1700000100,v1=") + kKnownMac;
    EXPECT_FALSE(VerifySignature(moved, "secret", kBody, kStamp + 100, 300));
}

TEST(WebhookSignature, FieldsInAnyOrderAndRotatedSignaturesVerify) {
    const std::string mac = kKnownMac;
    const std::string wrong(64, '0');
    EXPECT_TRUE(VerifySignature("v1=" + mac + ",t=1700000000", "secret", kBody, kStamp, 5));
    EXPECT_TRUE(VerifySignature("t=1700000000, v0=x, v1=" + wrong + ", v1=" + mac, "secret", kBody,
                                kStamp, 5));
    std::string upper = mac;
    for (char& c : upper) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    EXPECT_TRUE(VerifySignature("t=1700000000,v1=" + upper, "secret", kBody, kStamp, 5));
    EXPECT_FALSE(VerifySignature("t=1700000000,v1=" + wrong, "secret", kBody, kStamp, 5));
}

TEST(WebhookSignature, MalformedHeadersAreRefused) {
    const std::string mac = kKnownMac;
    const std::string headers[] = {
        "",
        "t=1700000000",
        "v1=" + mac,
        "t=1700000000,v1=" + mac.substr(1),
        "t=1700000000,v1=" + mac + "00",
        "t=1700000000,v1=" + mac.substr(2) + "zz",
        "t=1700000000,t=1700000000,v1=" + mac,
        "t=-1700000000,v1=" + mac,
        "t=+1700000000,v1=" + mac,
        "t=,v1=" + mac,
        "t=17e8,v1=" + mac,
        "t=1700000000,v1=" + mac + ",garbage",
        "t=9999999999999999999999,v1=" + mac,
        "t=1700000000;v1=" + mac,
        "t=1700000000,v1=" + mac + "," + std::string(5000, ' '),
    };
    for (const std::string& header : headers) {
        SCOPED_TRACE(header.substr(0, 80));
        EXPECT_FALSE(VerifySignature(header, "secret", kBody, kStamp, 300));
    }
}

TEST(WebhookSignature, ExtremeClocksDoNotOverflowTheToleranceCheck) {
    const std::string header = SignatureHeader("secret", kStamp, kBody);
    constexpr std::int64_t kMin = std::numeric_limits<std::int64_t>::min();
    constexpr std::int64_t kMax = std::numeric_limits<std::int64_t>::max();
    EXPECT_FALSE(VerifySignature(header, "secret", kBody, kMin, 300));
    EXPECT_FALSE(VerifySignature(header, "secret", kBody, kMax, 300));
    EXPECT_FALSE(VerifySignature(header, "secret", kBody, kMin, kMax)) << "2^63 + t apart";
    EXPECT_TRUE(VerifySignature(header, "secret", kBody, kMax, kMax));
}

}  // namespace
}  // namespace soilvol::server
