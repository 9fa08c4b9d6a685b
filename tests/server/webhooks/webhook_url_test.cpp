#include "server/webhooks/webhook_url.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace soilvol::server {
namespace {

TEST(WebhookUrl, HttpAndHttpsTakeTheirDefaultPortsAndTarget) {
    const absl::StatusOr<WebhookUrl> plain = ParseWebhookUrl("http://example.com");
    ASSERT_TRUE(plain.ok()) << plain.status();
    EXPECT_FALSE(plain->tls);
    EXPECT_EQ(plain->host, "example.com");
    EXPECT_EQ(plain->port, "80");
    EXPECT_EQ(plain->target, "/");
    const std::string text = "HTTPS://Hooks.Example.COM/v1/in?x=1&y=%2F";
    const absl::StatusOr<WebhookUrl> secure = ParseWebhookUrl(text);
    ASSERT_TRUE(secure.ok()) << secure.status();
    EXPECT_TRUE(secure->tls);
    EXPECT_EQ(secure->host, "hooks.example.com");
    EXPECT_EQ(secure->port, "443");
    EXPECT_EQ(secure->target, "/v1/in?x=1&y=%2F");
    EXPECT_EQ(secure->text, text);
}

TEST(WebhookUrl, PortsAndAddressLiteralsAreTakenApart) {
    const absl::StatusOr<WebhookUrl> v4 = ParseWebhookUrl("http://10.0.0.1:8080/a/b");
    ASSERT_TRUE(v4.ok()) << v4.status();
    EXPECT_EQ(v4->host, "10.0.0.1");
    EXPECT_EQ(v4->port, "8080");
    EXPECT_EQ(v4->target, "/a/b");
    const absl::StatusOr<WebhookUrl> v6 = ParseWebhookUrl("https://[::1]:8443/x");
    ASSERT_TRUE(v6.ok()) << v6.status();
    EXPECT_EQ(v6->host, "::1");
    EXPECT_EQ(v6->port, "8443");
    const absl::StatusOr<WebhookUrl> v6_default = ParseWebhookUrl("http://[2001:DB8::1]");
    ASSERT_TRUE(v6_default.ok()) << v6_default.status();
    EXPECT_EQ(v6_default->host, "2001:db8::1");
    EXPECT_EQ(v6_default->port, "80");
    const absl::StatusOr<WebhookUrl> padded = ParseWebhookUrl("http://h:00080");
    ASSERT_TRUE(padded.ok()) << padded.status();
    EXPECT_EQ(padded->port, "80");
    const absl::StatusOr<WebhookUrl> highest = ParseWebhookUrl("http://h:65535/");
    ASSERT_TRUE(highest.ok()) << highest.status();
    EXPECT_EQ(highest->port, "65535");
}

TEST(WebhookUrl, AQueryWithoutAPathTargetsTheRoot) {
    const absl::StatusOr<WebhookUrl> url = ParseWebhookUrl("http://h.example?event=load");
    ASSERT_TRUE(url.ok()) << url.status();
    EXPECT_EQ(url->host, "h.example");
    EXPECT_EQ(url->target, "/?event=load");
}

TEST(WebhookUrl, TheLongestUrlIsAcceptedAndOneMoreCharacterIsNot) {
    const std::string prefix = "http://h/";
    const std::string longest = prefix + std::string(kMaxWebhookUrlLength - prefix.size(), 'a');
    EXPECT_TRUE(ParseWebhookUrl(longest).ok());
    const absl::Status status = ParseWebhookUrl(longest + "a").status();
    EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(status.message().find("longer than 2048"), std::string::npos) << status;
}

struct HostileUrl {
    std::string url;
    std::string reason;  // a part of the message
};

std::vector<HostileUrl> HostileUrls() {
    return {
        {"", "no scheme"},
        {"javascript:alert(1)", "no scheme"},
        {"http:/h/", "no scheme"},
        {"ftp://h/", "scheme must be http or https"},
        {"file:///etc/passwd", "scheme must be http or https"},
        {"httpx://h/", "scheme must be http or https"},
        {"http://user:pw@h/", "user info"},
        {"http://@h/", "user info"},
        {"http://h/a#fragment", "fragment"},
        {"http://h/a b", "space at offset 10"},
        {"http://h/a\r\nX-Injected: 1", "control character at offset 10"},
        {std::string("http://h/\0x", 11), "control character at offset 9"},
        {"http://h\x7f/", "control character"},
        {"http://h\xc3\xa9.com/", "non-ASCII"},
        {"http://h/a\\b", "backslash"},
        {"http:///path", "empty host"},
        {"http://:80/", "empty host"},
        {"http://::1/", "empty host"},
        {"http://h:0/", "port out of range"},
        {"http://h:65536/", "port out of range"},
        {"http://h:99999999999999999999999/", "port out of range"},
        {"http://h:-1/", "port must be a decimal number"},
        {"http://h:/", "port must be a decimal number"},
        {"http://h:8a/", "port must be a decimal number"},
        {"http://h:+80/", "port must be a decimal number"},
        {"http://h:80:80/", "port must be a decimal number"},
        {"http://[::1/", "unclosed '['"},
        {"http://[::1]x/", "after the IPv6"},
        {"http://[fe80::1%25eth0]/", "IPv6"},
        {"http://[1.2.3.4]/", "IPv6"},
        {"http://[]/", "IPv6"},
        {"http://[::1]:0/", "port out of range"},
        {"http://256.1.1.1/", "IPv4"},
        {"http://1.2.3/", "IPv4"},
        {"http://010.0.0.1/", "IPv4"},
        {"http://0x7f.0.0.1/", "IPv4"},
        {"http://2130706433/", "IPv4"},
        {"http://a..b/", "label"},
        {"http://a.b./", "label"},
        {"http://" + std::string(64, 'a') + ".com/", "label"},
        {"http://" + std::string(250, 'a') + ".com/", "host longer than 253"},
        {"http://-a.com/", "'-'"},
        {"http://a-.com/", "'-'"},
        {"http://a_b.com/", "character '_' in the host"},
        {"http://exa%6dple.com/", "character '%' in the host"},
        {"http://h/<script>", "character '<' in the path or query"},
        {"http://h/a?b=\"c\"", "character '\"'"},
        {"http://h/%zz", "'%' not followed"},
        {"http://h/%4", "'%' not followed"},
        {"http://h/%", "'%' not followed"},
    };
}

TEST(WebhookUrl, HostileUrlsAreRefusedNamingWhatIsWrong) {
    for (const HostileUrl& hostile : HostileUrls()) {
        SCOPED_TRACE(hostile.url);
        const absl::StatusOr<WebhookUrl> url = ParseWebhookUrl(hostile.url);
        ASSERT_FALSE(url.ok()) << url->host << " " << url->port << " " << url->target;
        EXPECT_EQ(url.status().code(), absl::StatusCode::kInvalidArgument);
        EXPECT_EQ(url.status().message().rfind("webhook url: ", 0), 0u) << url.status();
        EXPECT_NE(url.status().message().find(hostile.reason), std::string::npos) << url.status();
    }
}

TEST(WebhookUrl, MessagesNeverRepeatTheUrl) {
    const absl::Status status = ParseWebhookUrl("https://admin:hunter2@h.example/").status();
    ASSERT_FALSE(status.ok());
    EXPECT_EQ(status.message().find("hunter2"), std::string::npos) << status;
    EXPECT_EQ(status.message().find("h.example"), std::string::npos) << status;
}

TEST(WebhookUrl, HostHeaderBracketsIpv6AndOmitsTheDefaultPort) {
    EXPECT_EQ(HostHeaderOf(*ParseWebhookUrl("http://h.example/")), "h.example");
    EXPECT_EQ(HostHeaderOf(*ParseWebhookUrl("https://h.example:443/")), "h.example");
    EXPECT_EQ(HostHeaderOf(*ParseWebhookUrl("https://h.example:80/")), "h.example:80");
    EXPECT_EQ(HostHeaderOf(*ParseWebhookUrl("http://[::1]:8080/")), "[::1]:8080");
    EXPECT_EQ(HostHeaderOf(*ParseWebhookUrl("http://[::1]/")), "[::1]");
}

}  // namespace
}  // namespace soilvol::server
