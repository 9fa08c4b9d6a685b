#include "server/store/entry_file.hpp"

#include <gtest/gtest.h>

#include <random>
#include <string>

#include "core/common/checksum.hpp"

namespace soilvol::server {
namespace {

std::string SomePayload(std::size_t size, uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::string payload(size, '\0');
    for (char& c : payload) c = static_cast<char>(rng());
    return payload;
}

uint64_t ReadU64(const std::string& bytes, std::size_t at) {
    uint64_t value = 0;
    for (int i = 7; i >= 0; --i) value = (value << 8) | static_cast<uint8_t>(bytes[at + i]);
    return value;
}

TEST(ChecksumTest, MatchesPublishedFnv1aVectors) {
    EXPECT_EQ(Fnv1a64(""), 0xcbf29ce484222325ull);
    EXPECT_EQ(Fnv1a64("a"), 0xaf63dc4c8601ec8cull);
    EXPECT_EQ(Fnv1a64("foobar"), 0x85944171f73967e8ull);
    EXPECT_EQ(Fnv1a64("bar", Fnv1a64("foo")), Fnv1a64("foobar"));
}

TEST(EntryFileTest, LayoutIsTheDocumentedLittleEndianEnvelope) {
    const std::string file = EncodeEntry(EntryKind::kContainer, "abc");
    ASSERT_EQ(file.size(), kEntryHeaderBytes + 3 + kEntryTrailerBytes);
    EXPECT_EQ(file.substr(0, 8), "SOILVOLE");
    EXPECT_EQ(file.substr(8, 4), std::string("\x01\x00\x00\x00", 4));
    EXPECT_EQ(file.substr(12, 4), std::string("\x02\x00\x00\x00", 4));
    EXPECT_EQ(file.substr(16, 8), std::string("\x03\0\0\0\0\0\0\0", 8));
    EXPECT_EQ(file.substr(24, 3), "abc");
    EXPECT_EQ(ReadU64(file, 27), Fnv1a64(file.substr(0, 27)));
    EXPECT_EQ(EncodeEntry(EntryKind::kCalibration, "")[12], '\x01');
}

TEST(EntryFileTest, RoundTripReturnsThePayload) {
    for (const std::size_t size : {0, 1, 7, 4096, 100000}) {
        const std::string payload = SomePayload(size, size);
        for (const EntryKind kind : {EntryKind::kCalibration, EntryKind::kContainer}) {
            const std::string file = EncodeEntry(kind, payload);
            const auto decoded = DecodeEntry(file, kind);
            ASSERT_TRUE(decoded.ok()) << decoded.status();
            EXPECT_EQ(*decoded, payload);
        }
    }
}

TEST(EntryFileTest, EnvelopeAroundPayloadEqualsEncodedFile) {
    const std::string payload = SomePayload(1000, 1);
    const EntryEnvelope envelope = EnvelopeFor(EntryKind::kCalibration, payload);
    EXPECT_EQ(envelope.header + payload + envelope.trailer,
              EncodeEntry(EntryKind::kCalibration, payload));
}

TEST(EntryFileTest, EveryTruncationIsDataLoss) {
    const std::string file = EncodeEntry(EntryKind::kContainer, SomePayload(300, 2));
    for (std::size_t n = 0; n < file.size(); ++n) {
        const auto decoded =
            DecodeEntry(std::string_view(file).substr(0, n), EntryKind::kContainer);
        ASSERT_EQ(decoded.status().code(), absl::StatusCode::kDataLoss) << n;
    }
}

TEST(EntryFileTest, TrailingBytesAreDataLoss) {
    const std::string file = EncodeEntry(EntryKind::kContainer, "payload");
    const auto decoded = DecodeEntry(file + "x", EntryKind::kContainer);
    EXPECT_EQ(decoded.status().code(), absl::StatusCode::kDataLoss);
    EXPECT_NE(decoded.status().message().find("payload size 7 but the file holds 8"),
              std::string::npos)
        << decoded.status();
}

TEST(EntryFileTest, EveryFlippedBitIsAnError) {
    const std::string file = EncodeEntry(EntryKind::kContainer, SomePayload(64, 3));
    for (std::size_t byte = 0; byte < file.size(); ++byte) {
        for (int bit = 0; bit < 8; ++bit) {
            std::string damaged = file;
            damaged[byte] = static_cast<char>(damaged[byte] ^ (1 << bit));
            const auto decoded = DecodeEntry(damaged, EntryKind::kContainer);
            ASSERT_FALSE(decoded.ok()) << byte << ":" << bit;
            // Only the version field may read as another version; all else is damage.
            const bool in_version = byte >= 8 && byte < 12;
            EXPECT_EQ(decoded.status().code(), in_version ? absl::StatusCode::kFailedPrecondition
                                                          : absl::StatusCode::kDataLoss)
                << byte << ":" << bit;
        }
    }
}

TEST(EntryFileTest, ChecksumMismatchSaysSo) {
    std::string file = EncodeEntry(EntryKind::kContainer, "payload");
    file[kEntryHeaderBytes] = 'P';
    const auto decoded = DecodeEntry(file, EntryKind::kContainer);
    EXPECT_EQ(decoded.status().code(), absl::StatusCode::kDataLoss);
    EXPECT_NE(decoded.status().message().find("checksum mismatch"), std::string::npos);
}

TEST(EntryFileTest, OtherSchemaVersionIsFailedPrecondition) {
    std::string file = EncodeEntry(EntryKind::kContainer, "payload");
    file[8] = 2;
    const auto decoded = DecodeEntry(file, EntryKind::kContainer);
    EXPECT_EQ(decoded.status().code(), absl::StatusCode::kFailedPrecondition);
    EXPECT_NE(decoded.status().message().find("version 2"), std::string::npos) << decoded.status();
}

TEST(EntryFileTest, OtherKindIsDataLoss) {
    const std::string file = EncodeEntry(EntryKind::kCalibration, "payload");
    const auto decoded = DecodeEntry(file, EntryKind::kContainer);
    EXPECT_EQ(decoded.status().code(), absl::StatusCode::kDataLoss);
    EXPECT_NE(decoded.status().message().find("container"), std::string::npos) << decoded.status();
}

TEST(EntryFileTest, GarbageAndForeignBytesAreDataLoss) {
    EXPECT_EQ(DecodeEntry("", EntryKind::kContainer).status().code(), absl::StatusCode::kDataLoss);
    EXPECT_EQ(DecodeEntry("SOILVOLM\x01\0\0\0", EntryKind::kContainer).status().code(),
              absl::StatusCode::kDataLoss);
    std::mt19937_64 rng(5);
    for (int i = 0; i < 200; ++i) {
        std::string junk = SomePayload(rng() % 512, rng());
        if (i % 2 == 0) junk = "SOILVOLE" + junk;
        if (i % 4 == 0 && junk.size() >= 12) junk.replace(8, 4, std::string("\x01\0\0\0", 4));
        EXPECT_FALSE(DecodeEntry(junk, EntryKind::kContainer).ok());
    }
}

// A crafted header with a huge size must not be trusted.
TEST(EntryFileTest, HugeDeclaredSizeIsDataLoss) {
    std::string file = EncodeEntry(EntryKind::kContainer, "payload");
    for (int i = 16; i < 24; ++i) file[i] = '\xff';
    EXPECT_EQ(DecodeEntry(file, EntryKind::kContainer).status().code(),
              absl::StatusCode::kDataLoss);
}

}  // namespace
}  // namespace soilvol::server
