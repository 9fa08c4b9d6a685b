#include "server/auth/authenticator.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <thread>

#include "google/protobuf/descriptor.h"
#include "soilvol/v1/soilvol.pb.h"

namespace soilvol::server {
namespace {

constexpr const char* kFleetToken = "fleet-token-0123456789abcdef";
constexpr const char* kOpsToken = "ops-token-fedcba9876543210";

std::string HexOf(const Sha256& hash) {
    std::string hex;
    char byte[3];
    for (const std::uint8_t b : hash) {
        std::snprintf(byte, sizeof(byte), "%02x", b);
        hex += byte;
    }
    return hex;
}

class TokenFileFixture : public ::testing::Test {
  protected:
    void SetUp() override {
        path_ = (std::filesystem::temp_directory_path() /
                 ("soilvol-tokens-" + std::to_string(::getpid()) + "-" +
                  ::testing::UnitTest::GetInstance()->current_test_info()->name()))
                    .string();
        Write("fleet read,estimate sha256:" + HexOf(Sha256Of(kFleetToken)) + "\n");
    }
    void TearDown() override { std::filesystem::remove(path_); }
    void Write(const std::string& text) {
        const std::string temp = path_ + ".new";
        std::ofstream(temp) << text;
        std::filesystem::rename(temp, path_);  // a new inode, as a Secret update makes
    }
    std::unique_ptr<Authenticator> Make() {
        auto authenticator = Authenticator::Create({path_, false, std::chrono::milliseconds(0)});
        EXPECT_TRUE(authenticator.ok()) << authenticator.status();
        return *std::move(authenticator);
    }
    std::string path_;
};

TEST(RequiredScope, EveryMethodOfTheServiceHasOne) {
    v1::Container linked;  // links the generated descriptors in
    const google::protobuf::ServiceDescriptor* service =
        google::protobuf::DescriptorPool::generated_pool()->FindServiceByName(
            "soilvol.v1.SoilVolume");
    ASSERT_NE(service, nullptr);
    for (int i = 0; i < service->method_count(); ++i) {
        EXPECT_TRUE(RequiredScope(service->method(i)->name()).ok()) << service->method(i)->name();
    }
    EXPECT_EQ(*RequiredScope("DeleteContainer"), Scope::kAdmin);
    EXPECT_EQ(*RequiredScope("ListContainers"), Scope::kRead);
    EXPECT_EQ(*RequiredScope("EstimateVolume"), Scope::kEstimate);
    EXPECT_TRUE(absl::IsNotFound(RequiredScope("Nope").status()));
}

TEST_F(TokenFileFixture, ScopesDecideBetweenAllowedAndPermissionDenied) {
    auto auth = Make();
    const std::string bearer = std::string("Bearer ") + kFleetToken;
    Principal who;
    const absl::Status allowed = auth->Authorize(Scope::kRead, bearer, "", &who);
    ASSERT_TRUE(allowed.ok()) << allowed;
    EXPECT_EQ(who.name, "fleet");
    EXPECT_EQ(who.via, "token");
    EXPECT_TRUE(auth->Authorize(Scope::kEstimate, bearer, "", &who).ok());
    Principal denied_who;
    const absl::Status denied = auth->Authorize(Scope::kAdmin, bearer, "", &denied_who);
    EXPECT_TRUE(absl::IsPermissionDenied(denied)) << denied;
    EXPECT_NE(denied.message().find("admin"), absl::string_view::npos);
    EXPECT_EQ(denied_who.name, "fleet");  // known, though not allowed: the audit line says who
    // The scheme is case-blind (RFC 7235).
    EXPECT_TRUE(auth->Authorize(Scope::kRead, std::string("bearer ") + kFleetToken, "", &who).ok());
}

TEST_F(TokenFileFixture, MissingMalformedOrUnknownTokensAreUnauthenticated) {
    auto auth = Make();
    for (const std::string& header :
         {std::string(), std::string("Bearer"), std::string("Bearer "),
          std::string("Basic ") + kFleetToken, std::string(kFleetToken),
          std::string("Bearer short"), std::string("Bearer ") + kFleetToken + "x",
          std::string("Bearer ") + std::string(5000, 'a'),
          std::string("Bearer fleet-token-0123456789abcde\x01")}) {
        Principal who;
        const absl::Status status = auth->Authorize(Scope::kRead, header, "", &who);
        EXPECT_TRUE(absl::IsUnauthenticated(status)) << header << ": " << status;
        EXPECT_EQ(who.name, "");
    }
}

TEST_F(TokenFileFixture, ChangedFileIsReadAgainAndABrokenOneKeepsThePrevious) {
    auto auth = Make();
    Principal who;
    Write("ops admin sha256:" + HexOf(Sha256Of(kOpsToken)) + "\n");
    EXPECT_TRUE(auth->Authorize(Scope::kAdmin, std::string("Bearer ") + kOpsToken, "", &who).ok());
    EXPECT_TRUE(absl::IsUnauthenticated(
        auth->Authorize(Scope::kRead, std::string("Bearer ") + kFleetToken, "", &who)));
    Write("ops admin sha256:not-a-hash\n");  // a rotation gone wrong
    EXPECT_TRUE(auth->Authorize(Scope::kAdmin, std::string("Bearer ") + kOpsToken, "", &who).ok());
}

TEST_F(TokenFileFixture, UnreadableOrInvalidFileStopsTheStart) {
    EXPECT_TRUE(
        absl::IsInvalidArgument(Authenticator::Create({path_ + ".missing", false}).status()));
    Write("fleet read\n");
    const absl::Status status = Authenticator::Create({path_, false}).status();
    EXPECT_TRUE(absl::IsInvalidArgument(status));
    EXPECT_NE(status.message().find("--auth-tokens-file"), absl::string_view::npos);
}

TEST(Authenticator, OpenServerLetsAnyoneIn) {
    auto auth = Authenticator::Create({});
    ASSERT_TRUE(auth.ok());
    EXPECT_TRUE((*auth)->open());
    Principal who;
    ASSERT_TRUE((*auth)->Authorize(Scope::kAdmin, "", "", &who).ok());
    EXPECT_EQ(who.via, "none");
}

TEST(Authenticator, ClientCertificatesAloneAuthenticateByTheirSubject) {
    auto auth = Authenticator::Create({"", true});
    ASSERT_TRUE(auth.ok());
    EXPECT_FALSE((*auth)->open());
    Principal who;
    ASSERT_TRUE((*auth)->Authorize(Scope::kAdmin, "", "CN=loader-3", &who).ok());
    EXPECT_EQ(who.name, "CN=loader-3");
    EXPECT_TRUE(absl::IsUnauthenticated((*auth)->Authorize(Scope::kRead, "", "", &who)));
}

}  // namespace
}  // namespace soilvol::server
