#include "server/store/entry_id.hpp"

#include <gtest/gtest.h>

#include <string>

#include "tests/server/store/has_substr.hpp"

namespace soilvol::server {
namespace {

std::string Message(std::string_view id) {
    return std::string(ValidateId(id, "container id").message());
}

TEST(EntryIdTest, PlainIdsAreAccepted) {
    for (const char* id : {"a", "Z", "7", "bucket-3", "truck_A.v2", "0.-_", "a..b", "x-"}) {
        EXPECT_TRUE(ValidateId(id, "container id").ok()) << id;
    }
    EXPECT_TRUE(ValidateId(std::string(64, 'k'), "container id").ok());
}

TEST(EntryIdTest, EmptyIdIsRejected) {
    const absl::Status status = ValidateId("", "calibration id");
    EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
    EXPECT_EQ(status.message(), "calibration id: is empty");
}

TEST(EntryIdTest, SixtyFiveCharactersAreTooLong) {
    const absl::Status status = ValidateId(std::string(65, 'k'), "container id");
    EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
    EXPECT_TRUE(HasSubstr(status.message(), "too long (65 characters, limit 64)"));
}

TEST(EntryIdTest, PathsCannotEscapeTheFolder) {
    for (const char* id : {"../x", "..", ".", "/etc/passwd", "a/b", "a\\b", "x/../../y"}) {
        EXPECT_EQ(ValidateId(id, "container id").code(), absl::StatusCode::kInvalidArgument) << id;
    }
    EXPECT_TRUE(HasSubstr(Message("a/b"), "bad character '/' at position 1"));
    EXPECT_TRUE(HasSubstr(Message("../x"), "must start with a letter or digit, not '.'"));
}

TEST(EntryIdTest, HiddenAndDashedNamesAreRejected) {
    EXPECT_TRUE(HasSubstr(Message(".hidden"), "must start with a letter or digit, not '.'"));
    EXPECT_TRUE(HasSubstr(Message("-rf"), "not '-'"));
    EXPECT_TRUE(HasSubstr(Message("_x"), "not '_'"));
}

TEST(EntryIdTest, NonPrintableBytesAreEscapedInTheMessage) {
    EXPECT_TRUE(
        HasSubstr(Message(std::string("ab\0cd", 5)), "bad character '\\x00' at position 2"));
    EXPECT_TRUE(HasSubstr(Message(std::string("\0ab", 3)), "not '\\x00'"));
    EXPECT_TRUE(HasSubstr(Message("ab\ncd"), "'\\n' at position 2"));
    EXPECT_TRUE(HasSubstr(Message("a b"), "' ' at position 1"));
    // "café": the first byte of the two-byte UTF-8 'é' is reported.
    EXPECT_TRUE(HasSubstr(Message("caf\xc3\xa9"), "'\\xc3' at position 3"));
    EXPECT_TRUE(HasSubstr(Message("\xc3\xa9t\xc3\xa9"), "not '\\xc3'"));
}

TEST(EntryIdTest, MessageNamesTheField) {
    EXPECT_TRUE(HasSubstr(ValidateId("a b", "calibration_id").message(),
                          "calibration_id: has a bad character"));
}

}  // namespace
}  // namespace soilvol::server
