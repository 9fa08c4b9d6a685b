#include "server/auth/token_file.hpp"

#include <gtest/gtest.h>

#include <string>

namespace soilvol::server {
namespace {

// sha256("correct horse battery staple")
constexpr const char* kHash = "c4bbcb1fbec99d65bf59d85c8cb62ee2db963f0fe106f483d9afa73bd4e39a8a";

std::string Line(const std::string& name, const std::string& scopes, const std::string& hash) {
    return name + " " + scopes + " sha256:" + hash + "\n";
}

TEST(TokenFile, Sha256MatchesTheStandardVector) {
    const Sha256 hash = Sha256Of("abc");
    EXPECT_EQ(hash[0], 0xba);
    EXPECT_EQ(hash[1], 0x78);
    EXPECT_EQ(hash[31], 0xad);  // ba7816bf...f20015ad
}

TEST(TokenFile, ParsesNamesScopesAndHashesWithComments) {
    const std::string text = "# fleet tokens\n\n" + Line("fleet-7", "read,estimate", kHash) +
                             "ops@site  admin\tsha256:" + std::string(64, 'A') + "  # rotated\n";
    absl::StatusOr<std::vector<TokenEntry>> tokens = ParseTokenFile(text);
    ASSERT_TRUE(tokens.ok()) << tokens.status();
    ASSERT_EQ(tokens->size(), 2u);
    EXPECT_EQ((*tokens)[0].name, "fleet-7");
    EXPECT_TRUE((*tokens)[0].Allows(Scope::kRead));
    EXPECT_TRUE((*tokens)[0].Allows(Scope::kEstimate));
    EXPECT_FALSE((*tokens)[0].Allows(Scope::kAdmin));
    EXPECT_EQ((*tokens)[0].sha256, Sha256Of("correct horse battery staple"));
    EXPECT_TRUE((*tokens)[1].Allows(Scope::kRead));  // admin implies the others
    EXPECT_TRUE((*tokens)[1].Allows(Scope::kEstimate));
    EXPECT_EQ((*tokens)[1].sha256[0], 0xaa);
}

TEST(TokenFile, EmptyFileHasNoTokens) {
    absl::StatusOr<std::vector<TokenEntry>> tokens = ParseTokenFile("# none yet\n");
    ASSERT_TRUE(tokens.ok());
    EXPECT_TRUE(tokens->empty());
}

TEST(TokenFile, HostileLinesAreRefusedNamingTheLine) {
    const std::string good = Line("a", "read", kHash);
    const std::vector<std::string> bad = {
        "a read\n",                                            // two words
        "a read sha256:" + std::string(64, 'a') + " extra\n",  // four
        Line("a", "write", kHash),                             // unknown scope
        Line("a", "read,", kHash),                             // empty scope
        Line("a", "read", std::string(63, 'a')),               // short hash
        Line("a", "read", std::string(63, 'a') + "g"),         // not hex
        "a read md5:" + std::string(64, 'a') + "\n",           // not sha256
        Line(std::string(65, 'n'), "read", kHash),             // long name
        Line("a/b", "read", kHash),                            // name outside the alphabet
        Line("a\x01", "read", kHash),                          // control character
        good + Line("a", "admin", std::string(64, 'b')),       // duplicate name
        good + Line("b", "admin", kHash),                      // duplicate hash
    };
    for (const std::string& text : bad) {
        absl::StatusOr<std::vector<TokenEntry>> tokens = ParseTokenFile(text);
        EXPECT_TRUE(absl::IsInvalidArgument(tokens.status())) << text;
        EXPECT_NE(tokens.status().message().find("line"), absl::string_view::npos) << text;
    }
}

TEST(TokenFile, SizeAndCountAreBounded) {
    EXPECT_FALSE(ParseTokenFile(std::string(kMaxTokenFileBytes + 1, '#')).ok());
    std::string many;
    char hash[65];
    for (std::size_t i = 0; i <= kMaxTokens; ++i) {
        std::snprintf(hash, sizeof(hash), "%064zx", i);
        many += Line("t" + std::to_string(i), "read", hash);
    }
    const absl::StatusOr<std::vector<TokenEntry>> tokens = ParseTokenFile(many);
    ASSERT_FALSE(tokens.ok());
    EXPECT_NE(tokens.status().message().find("more than"), absl::string_view::npos);
}

}  // namespace
}  // namespace soilvol::server
