#include "server/http/multipart.hpp"

#include <gtest/gtest.h>

#include <string>

namespace soilvol::server {
namespace {

std::string Part(const std::string& headers, const std::string& data) {
    return "--XyZ\r\n" + headers + "\r\n\r\n" + data + "\r\n";
}

const std::string kClose = "--XyZ--\r\n";

TEST(Multipart, BoundaryFromTheContentType) {
    EXPECT_EQ(*MultipartBoundary("multipart/form-data; boundary=XyZ"), "XyZ");
    EXPECT_EQ(*MultipartBoundary("Multipart/Form-Data;boundary=\"a b'()+_,-./:=?\""),
              "a b'()+_,-./:=?");
    EXPECT_EQ(*MultipartBoundary("multipart/form-data; charset=x; boundary=q1"), "q1");
    for (const char* bad :
         {"multipart/form-data", "multipart/form-data; boundary=", "multipart/mixed; boundary=a",
          "application/json; boundary=a", "multipart/form-data; boundary=\"ends in space \"",
          "multipart/form-data; boundary=\"unterminated", "multipart/form-data; boundary=a\x01"}) {
        const auto status = MultipartBoundary(bad).status();
        EXPECT_TRUE(absl::IsInvalidArgument(status)) << bad;
        EXPECT_EQ(status.message().substr(0, 13), "Content-Type:") << bad;
    }
    EXPECT_FALSE(MultipartBoundary("multipart/form-data; boundary=" + std::string(71, 'a')).ok());
    EXPECT_TRUE(MultipartBoundary("multipart/form-data; boundary=" + std::string(70, 'a')).ok());
}

TEST(Multipart, PartsWithNamesFilesAndTypes) {
    const std::string body =
        "preamble is ignored\r\n" +
        Part("Content-Disposition: form-data; name=\"request\"\r\nContent-Type: application/json",
             "{\"a\": 1}") +
        Part("content-disposition: form-data; name=cloud; filename=\"scan;1.ply\"",
             std::string("ply\r\n--XyA-not-a-delimiter\0binary", 30)) +
        Part("Content-Disposition: form-data; name=\"empty\"", "") + kClose + "epilogue";
    const auto parts = ParseMultipart(body, "XyZ");
    ASSERT_TRUE(parts.ok()) << parts.status();
    ASSERT_EQ(parts->size(), 3u);
    EXPECT_EQ((*parts)[0].name, "request");
    EXPECT_EQ((*parts)[0].content_type, "application/json");
    EXPECT_EQ((*parts)[0].data, "{\"a\": 1}");
    EXPECT_EQ((*parts)[1].name, "cloud");
    EXPECT_EQ((*parts)[1].filename, "scan;1.ply");
    EXPECT_EQ((*parts)[1].data, std::string("ply\r\n--XyA-not-a-delimiter\0binary", 30));
    EXPECT_EQ((*parts)[2].name, "empty");
    EXPECT_TRUE((*parts)[2].data.empty());
}

TEST(Multipart, MalformedBodiesAreRefusedWithTheReason) {
    const std::string good = Part("Content-Disposition: form-data; name=a", "x");
    const std::pair<std::string, std::string> cases[] = {
        {"", "no boundary delimiter"},
        {"no delimiter at all", "no boundary delimiter"},
        {good, "no closing boundary delimiter"},
        {"--XyZ\r\nContent-Disposition: form-data; name=a\r\n\r\nx", "no closing boundary"},
        {"--XyZ\r\nContent-Disposition: form-data; name=a", "ends inside its header block"},
        {"--XyZ garbage\r\n", "does not start with CRLF"},
        {Part("Content-Type: text/plain", "x") + kClose, "no Content-Disposition"},
        {Part("Content-Disposition: attachment; name=a", "x") + kClose, "is not form-data"},
        {Part("Content-Disposition: form-data", "x") + kClose, "has no name"},
        {Part("Content-Disposition: form-data; name=\"\"", "x") + kClose, "has no name"},
        {Part("Content-Disposition: form-data; name=\"a", "x") + kClose, "has no name"},
        {Part("Content-Disposition: form-data; name=a\r\nContent-Disposition: form-data; name=b",
              "x") +
             kClose,
         "two Content-Disposition"},
        {Part("Content-Disposition: form-data; name=a\r\nno colon here", "x") + kClose,
         "without a name"},
        {Part("Content-Disposition: form-data; name=a\r\nContent-Type: multipart/mixed", "x") +
             kClose,
         "itself multipart"},
        {"--XyZ\r\n" + std::string(9000, 'h') + "\r\n\r\nx\r\n" + kClose, "over the limit"},
    };
    for (const auto& [body, reason] : cases) {
        const auto parts = ParseMultipart(body, "XyZ");
        ASSERT_FALSE(parts.ok()) << body.substr(0, 80);
        EXPECT_TRUE(absl::IsInvalidArgument(parts.status()));
        EXPECT_NE(parts.status().message().find(reason), std::string::npos)
            << parts.status() << " for " << body.substr(0, 80);
    }
}

TEST(Multipart, PartCountIsBounded) {
    std::string body;
    for (int i = 0; i < 10000; ++i) body += Part("Content-Disposition: form-data; name=p", "x");
    body += kClose;
    const auto parts = ParseMultipart(body, "XyZ");
    ASSERT_FALSE(parts.ok());
    EXPECT_NE(parts.status().message().find("more than 16 parts"), std::string::npos);
    MultipartLimits limits;
    limits.max_parts = 10000;
    EXPECT_EQ(ParseMultipart(body, "XyZ", limits)->size(), 10000u);
}

TEST(Multipart, NoPartsIsAnEmptyList) {
    const auto parts = ParseMultipart(kClose, "XyZ");
    ASSERT_TRUE(parts.ok());
    EXPECT_TRUE(parts->empty());
}

}  // namespace
}  // namespace soilvol::server
