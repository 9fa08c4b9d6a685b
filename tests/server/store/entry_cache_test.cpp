#include "server/store/entry_cache.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <string>
#include <thread>
#include <vector>

#include "tests/server/store/scratch_dir.hpp"

namespace soilvol::server {
namespace {

constexpr EntryKind kCached = EntryKind::kContainer;

struct Decoded {
    std::string text;
    int serial = 0;  // which decode produced it
};

class EntryCacheTest : public ::testing::Test {
  protected:
    void SetUp() override {
        for (std::unique_ptr<EntryStore>* store : {&store_, &other_}) {
            auto opened = EntryStore::Open(dir_.path());
            ASSERT_TRUE(opened.ok()) << opened.status();
            *store = std::move(opened).value();
        }
    }
    // Refuses payloads starting with "bad"; counts decodes.
    EntryCache<Decoded>::Decoder Decoder() {
        return [this](const StoredEntry& entry) -> absl::StatusOr<Decoded> {
            const int serial = ++decodes_;
            if (entry.payload.rfind("bad", 0) == 0) return absl::InvalidArgumentError("bad model");
            return Decoded{entry.payload, serial};
        };
    }

    ScratchDir dir_;
    std::unique_ptr<EntryStore> store_;
    std::unique_ptr<EntryStore> other_;  // a second server process on the same directory
    std::atomic<int> decodes_{0};
};

TEST_F(EntryCacheTest, UnchangedEntryReturnsTheSamePointer) {
    EntryCache<Decoded> cache(*store_, Decoder());
    ASSERT_TRUE(store_->Put(kCached, "x", "v1", false).ok());
    const auto first = cache.Get(kCached, "x");
    ASSERT_TRUE(first.ok()) << first.status();
    EXPECT_EQ((*first)->text, "v1");
    for (int i = 0; i < 5; ++i) EXPECT_EQ(*cache.Get(kCached, "x"), *first);
    EXPECT_EQ(decodes_, 1);
    EXPECT_EQ(cache.size(), 1u);
}

TEST_F(EntryCacheTest, OverwriteByAnotherStoreIsSeen) {
    EntryCache<Decoded> cache(*store_, Decoder());
    ASSERT_TRUE(store_->Put(kCached, "x", "v1", false).ok());
    const auto first = cache.Get(kCached, "x");
    ASSERT_TRUE(first.ok());
    // Same size and (likely) the same mtime tick: the new file's inode tells them apart.
    ASSERT_TRUE(other_->Put(kCached, "x", "v2", true).ok());
    const auto second = cache.Get(kCached, "x");
    ASSERT_TRUE(second.ok());
    EXPECT_EQ((*second)->text, "v2");
    EXPECT_NE(*second, *first);
    EXPECT_EQ((*first)->text, "v1");  // holders of the old value keep it
    EXPECT_EQ(*cache.Get(kCached, "x"), *second);
    EXPECT_EQ(decodes_, 2);
}

TEST_F(EntryCacheTest, DeletedEntryIsNotFoundAndDropped) {
    EntryCache<Decoded> cache(*store_, Decoder());
    ASSERT_TRUE(store_->Put(kCached, "x", "v1", false).ok());
    ASSERT_TRUE(cache.Get(kCached, "x").ok());
    ASSERT_TRUE(other_->Delete(kCached, "x").ok());
    const auto gone = cache.Get(kCached, "x");
    EXPECT_EQ(gone.status().code(), absl::StatusCode::kNotFound);
    EXPECT_EQ(cache.size(), 0u);
    // Registered again under the same id: the new content, not the old value.
    ASSERT_TRUE(other_->Put(kCached, "x", "v3", false).ok());
    EXPECT_EQ((*cache.Get(kCached, "x"))->text, "v3");
}

TEST_F(EntryCacheTest, ErrorsAreNotCached) {
    EntryCache<Decoded> cache(*store_, Decoder());
    ASSERT_TRUE(store_->Put(kCached, "x", "bad bytes", false).ok());
    for (int i = 0; i < 3; ++i) {
        EXPECT_EQ(cache.Get(kCached, "x").status().code(), absl::StatusCode::kInvalidArgument);
    }
    EXPECT_EQ(decodes_, 3);
    EXPECT_EQ(cache.size(), 0u);
    EXPECT_EQ(cache.Get(kCached, "missing").status().code(), absl::StatusCode::kNotFound);
    EXPECT_EQ(cache.Get(kCached, "../x").status().code(), absl::StatusCode::kInvalidArgument);
    ASSERT_TRUE(store_->Put(kCached, "x", "good", true).ok());
    EXPECT_EQ((*cache.Get(kCached, "x"))->text, "good");
}

TEST_F(EntryCacheTest, DamagedFileIsDataLossAndDropsTheOldValue) {
    EntryCache<Decoded> cache(*store_, Decoder());
    ASSERT_TRUE(store_->Put(kCached, "x", "v1", false).ok());
    ASSERT_TRUE(cache.Get(kCached, "x").ok());
    const std::filesystem::path file = dir_.path() / "containers" / "x.entry";
    std::filesystem::resize_file(file, 10);
    EXPECT_EQ(cache.Get(kCached, "x").status().code(), absl::StatusCode::kDataLoss);
    EXPECT_EQ(cache.size(), 0u);
}

TEST_F(EntryCacheTest, LeastRecentlyUsedIsEvicted) {
    EntryCache<Decoded> cache(*store_, Decoder(), 2);
    for (const char* id : {"a", "b", "c"}) ASSERT_TRUE(store_->Put(kCached, id, id, false).ok());
    ASSERT_TRUE(cache.Get(kCached, "a").ok());
    ASSERT_TRUE(cache.Get(kCached, "b").ok());
    ASSERT_TRUE(cache.Get(kCached, "a").ok());
    ASSERT_TRUE(cache.Get(kCached, "c").ok());  // evicts b
    EXPECT_EQ(cache.size(), 2u);
    EXPECT_EQ(decodes_, 3);
    ASSERT_TRUE(cache.Get(kCached, "a").ok());
    EXPECT_EQ(decodes_, 3);
    ASSERT_TRUE(cache.Get(kCached, "b").ok());
    EXPECT_EQ(decodes_, 4);
}

TEST_F(EntryCacheTest, KindsAreCachedSeparately) {
    EntryCache<Decoded> cache(*store_, Decoder());
    ASSERT_TRUE(store_->Put(kCached, "x", "container", false).ok());
    ASSERT_TRUE(store_->Put(EntryKind::kCalibration, "x", "calibration", false).ok());
    EXPECT_EQ((*cache.Get(kCached, "x"))->text, "container");
    EXPECT_EQ((*cache.Get(EntryKind::kCalibration, "x"))->text, "calibration");
}

// Readers racing a writer in another "process" only ever see complete values.
TEST_F(EntryCacheTest, ConcurrentReadersSeeWholeValues) {
    EntryCache<Decoded> cache(*store_, Decoder(), 4);
    ASSERT_TRUE(store_->Put(kCached, "x", std::string(1000, 'a'), false).ok());
    std::atomic<bool> stop{false};
    std::thread writer([&] {
        for (int i = 0; !stop; ++i) {
            (void)other_->Put(kCached, "x", std::string(1000 + i % 7, 'a' + i % 26), true);
        }
    });
    std::vector<std::thread> readers;
    std::atomic<int> failures{0};
    for (int t = 0; t < 4; ++t) {
        readers.emplace_back([&] {
            for (int i = 0; i < 300; ++i) {
                const auto value = cache.Get(kCached, "x");
                if (!value.ok()) {
                    ++failures;
                    continue;
                }
                const std::string& text = (*value)->text;
                if (text.size() < 1000 || text.find_first_not_of(text[0]) != std::string::npos) {
                    ++failures;
                }
            }
        });
    }
    for (std::thread& r : readers) r.join();
    stop = true;
    writer.join();
    EXPECT_EQ(failures, 0);
}

}  // namespace
}  // namespace soilvol::server
