#include "server/handlers/resource_rules.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <set>
#include <string>
#include <vector>

#include "absl/strings/escaping.h"
#include "server/base/status_map.hpp"

namespace soilvol::server {
namespace {

std::vector<std::string> Ids(int n) {
    std::vector<std::string> ids;
    for (int i = 0; i < n; ++i) ids.push_back("c" + std::to_string(1000 + i));
    return ids;
}

TEST(ResourceRules, PagesWalkTheListOnceInOrder) {
    const std::vector<std::string> ids = Ids(25);
    std::vector<std::string> seen;
    std::string token;
    int pages = 0;
    do {
        absl::StatusOr<Page> page = PageOf(ids, 10, token);
        ASSERT_TRUE(page.ok()) << page.status();
        seen.insert(seen.end(), page->ids.begin(), page->ids.end());
        token = page->next_page_token;
        ++pages;
    } while (!token.empty());
    EXPECT_EQ(pages, 3);
    EXPECT_EQ(seen, ids);
}

TEST(ResourceRules, PageSizeDefaultsAndCaps) {
    EXPECT_EQ(PageOf(Ids(150), 0, "")->ids.size(), static_cast<std::size_t>(kDefaultPageSize));
    EXPECT_EQ(PageOf(Ids(1500), 5000, "")->ids.size(), static_cast<std::size_t>(kMaxPageSize));
    EXPECT_TRUE(PageOf(Ids(3), 0, "")->next_page_token.empty());
    EXPECT_TRUE(PageOf({}, 0, "")->ids.empty());
    const absl::Status negative = PageOf(Ids(3), -1, "").status();
    EXPECT_TRUE(absl::IsInvalidArgument(negative));
    EXPECT_EQ(FieldOf(negative.message()), "page_size");
}

TEST(ResourceRules, EntriesChangingBetweenPagesNeitherRepeatNorShift) {
    std::vector<std::string> ids = Ids(6);
    const Page first = *PageOf(ids, 3, "");
    ids.erase(ids.begin());              // an entry of the first page is deleted
    ids.insert(ids.begin(), "a-first");  // one sorting before everything is created
    const Page second = *PageOf(ids, 3, first.next_page_token);
    EXPECT_EQ(second.ids, (std::vector<std::string>{"c1003", "c1004", "c1005"}));
}

TEST(ResourceRules, ForeignPageTokensAreRefused) {
    for (const std::string& token :
         {std::string("garbage!"), absl::WebSafeBase64Escape("before:c1"),
          absl::WebSafeBase64Escape("after:../etc"), std::string(300, 'A')}) {
        const absl::Status status = PageOf(Ids(3), 0, token).status();
        EXPECT_TRUE(absl::IsInvalidArgument(status)) << token;
        EXPECT_EQ(FieldOf(status.message()), "page_token");
    }
}

TEST(ResourceRules, RequestIds) {
    EXPECT_TRUE(ValidateRequestId("", "request_id").ok());
    EXPECT_TRUE(ValidateRequestId("f81d4fae-7dec-11d0-a765-00a0c91e6bf6", "request_id").ok());
    EXPECT_TRUE(ValidateRequestId(std::string(128, 'x'), "request_id").ok());
    for (const std::string& bad : {std::string(129, 'x'), std::string("a b"), std::string("a/b")}) {
        const absl::Status status = ValidateRequestId(bad, "request_id");
        EXPECT_TRUE(absl::IsInvalidArgument(status)) << bad;
        EXPECT_EQ(FieldOf(status.message()), "request_id");
    }
}

TEST(ResourceRules, ServerChosenIdsFollowTheRequestId) {
    EXPECT_EQ(ServerChosenId("ctr", "r-1"), ServerChosenId("ctr", "r-1"));
    EXPECT_NE(ServerChosenId("ctr", "r-1"), ServerChosenId("ctr", "r-2"));
    EXPECT_NE(ServerChosenId("ctr", "r-1"), ServerChosenId("cal", "r-1"));
    EXPECT_NE(ServerChosenId("ctr", ""), ServerChosenId("ctr", ""));
    EXPECT_EQ(ServerChosenId("ctr", "").size(), 16u);
    EXPECT_EQ(ServerChosenId("ctr", "x").rfind("ctr-", 0), 0u);
}

TEST(ResourceRules, Etags) {
    std::set<std::string> etags;
    for (int i = 0; i < 100; ++i) etags.insert(NewEtag());
    EXPECT_EQ(etags.size(), 100u);
    EXPECT_EQ(EtagOf("abc"), EtagOf("abc"));
    EXPECT_NE(EtagOf("abc"), EtagOf("abd"));
    EXPECT_TRUE(CheckEtag("", "e1", "'a'").ok());
    EXPECT_TRUE(CheckEtag("e1", "e1", "'a'").ok());
    const absl::Status stale = CheckEtag("e0", "e1", "'a'");
    EXPECT_TRUE(absl::IsAborted(stale));
    EXPECT_EQ(FieldOf(stale.message()), "etag");
}

TEST(ResourceRules, DisplayNamesAndLabels) {
    EXPECT_TRUE(ValidateDisplayName("Truck 7 \xC3\xA9", "display_name").ok());
    EXPECT_TRUE(ValidateDisplayName("", "display_name").ok());
    EXPECT_EQ(FieldOf(ValidateDisplayName(std::string(201, 'a'), "display_name").message()),
              "display_name");
    EXPECT_FALSE(ValidateDisplayName("a\nb", "display_name").ok());
    EXPECT_TRUE(ValidateLabel("site", "north-pit_2", "labels").ok());
    EXPECT_TRUE(ValidateLabel("fleet.kind", "", "labels").ok());
    for (const std::string& bad_key :
         std::vector<std::string>{"", "Site", "1st", "a b", std::string(64, 'a')}) {
        const absl::Status status = ValidateLabel(bad_key, "v", "labels");
        EXPECT_TRUE(absl::IsInvalidArgument(status)) << bad_key;
        EXPECT_EQ(FieldOf(status.message()), "labels") << status.message();
    }
    for (const std::string& bad_value :
         std::vector<std::string>{"a b", "x/y", std::string(64, 'v')}) {
        EXPECT_TRUE(absl::IsInvalidArgument(ValidateLabel("k", bad_value, "labels"))) << bad_value;
    }
}

TEST(ResourceRules, RecordIdsAndTokensRefuseHostileText) {
    EXPECT_EQ(*ParseRecordId("42", "estimate_id"), 42);
    EXPECT_EQ(*ParseRecordId("9223372036854775807", "estimate_id"), INT64_MAX);
    for (const std::string& bad : std::vector<std::string>{
             "", "0", "02", "-1", "+1", " 1", "1 ", "1e3", "0x10", "abc", "99999999999999999999",
             std::string(1000, '9'), std::string("1\0", 2)}) {
        const absl::StatusOr<std::int64_t> id = ParseRecordId(bad, "estimate_id");
        EXPECT_TRUE(absl::IsInvalidArgument(id.status())) << bad;
        EXPECT_EQ(FieldOf(id.status().message()), "estimate_id");
    }
    // A watch resumes after an id, or from the first kept ("0"); nothing else more.
    EXPECT_EQ(*ParseResumeId("0", "after_estimate_id"), 0);
    EXPECT_EQ(*ParseResumeId("42", "after_estimate_id"), 42);
    for (const std::string& bad : std::vector<std::string>{"", "00", "-0", "+0", "0 ", "x"}) {
        const absl::StatusOr<std::int64_t> id = ParseResumeId(bad, "after_estimate_id");
        EXPECT_TRUE(absl::IsInvalidArgument(id.status())) << bad;
        EXPECT_EQ(FieldOf(id.status().message()), "after_estimate_id");
    }
    EXPECT_FALSE(ParseRecordPageToken("")->has_value());
    EXPECT_EQ(**ParseRecordPageToken(RecordPageToken(17)), 17);
    for (const std::string& bad :
         std::vector<std::string>{"x", "bm9wZQ", RecordPageToken(0), RecordPageToken(-5),
                                  std::string(100, 'A'), "%%%", std::string("\xff\x00", 2)}) {
        const auto token = ParseRecordPageToken(bad);
        EXPECT_TRUE(absl::IsInvalidArgument(token.status())) << bad;
        EXPECT_EQ(FieldOf(token.status().message()), "page_token");
    }
}

}  // namespace
}  // namespace soilvol::server
