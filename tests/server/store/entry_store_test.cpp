#include "server/store/entry_store.hpp"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <fstream>
#include <functional>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "tests/server/store/has_substr.hpp"
#include "tests/server/store/scratch_dir.hpp"

namespace soilvol::server {
namespace {

namespace fs = std::filesystem;
using Ids = std::vector<std::string>;
constexpr EntryKind kContainer = EntryKind::kContainer;
constexpr EntryKind kCalibration = EntryKind::kCalibration;

void WriteFile(const fs::path& path, const std::string& bytes) {
    std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

std::string ReadFile(const fs::path& path) {
    std::string bytes(fs::file_size(path), '\0');
    std::ifstream(path, std::ios::binary).read(bytes.data(), static_cast<long>(bytes.size()));
    return bytes;
}

// Every name in a folder, sorted, including temp files and dotfiles.
Ids Names(const fs::path& folder) {
    Ids names;
    for (const auto& entry : fs::directory_iterator(folder)) {
        names.push_back(entry.path().filename());
    }
    std::sort(names.begin(), names.end());
    return names;
}

bool HasTempFile(const fs::path& folder) {
    const Ids names = Names(folder);
    return std::any_of(names.begin(), names.end(),
                       [](const std::string& n) { return n.find(".tmp") != std::string::npos; });
}

void SetAge(const fs::path& path, std::chrono::seconds age) {
    timespec times[2];
    ASSERT_EQ(::clock_gettime(CLOCK_REALTIME, &times[0]), 0);
    times[0].tv_sec -= age.count();
    times[1] = times[0];
    ASSERT_EQ(::utimensat(AT_FDCWD, path.c_str(), times, 0), 0);
}

class EntryStoreTest : public ::testing::Test {
  protected:
    void SetUp() override {
        auto opened = EntryStore::Open(dir_.path());
        ASSERT_TRUE(opened.ok()) << opened.status();
        store_ = std::move(opened).value();
    }
    fs::path Containers() const { return dir_.path() / "containers"; }

    ScratchDir dir_;
    std::unique_ptr<EntryStore> store_;
};

TEST_F(EntryStoreTest, OpenCreatesTheKindFolders) {
    EXPECT_EQ(Names(dir_.path()), (Ids{"calibrations", "containers"}));
    EXPECT_EQ(store_->root(), dir_.path());
    EXPECT_TRUE(store_->List(kContainer).empty());
    const auto nested = EntryStore::Open(dir_.path() / "a" / "b");
    ASSERT_TRUE(nested.ok()) << nested.status();
    EXPECT_TRUE(fs::is_directory(dir_.path() / "a" / "b" / "calibrations"));
}

TEST_F(EntryStoreTest, OpenOnARegularFileIsFailedPrecondition) {
    const fs::path file = dir_.path() / "plain";
    WriteFile(file, "x");
    for (const fs::path& root : {file, file / "below"}) {
        const auto opened = EntryStore::Open(root);
        EXPECT_EQ(opened.status().code(), absl::StatusCode::kFailedPrecondition) << root;
        EXPECT_TRUE(HasSubstr(opened.status().message(), file.string()));
    }
    // A file where a kind folder belongs.
    const fs::path root = dir_.path() / "r";
    fs::create_directory(root);
    WriteFile(root / "containers", "x");
    const auto opened = EntryStore::Open(root);
    EXPECT_EQ(opened.status().code(), absl::StatusCode::kFailedPrecondition);
    EXPECT_TRUE(HasSubstr(opened.status().message(), "is not a directory"));
}

TEST_F(EntryStoreTest, PutThenGetReturnsThePayloadAndStamp) {
    const std::string payload("model\0bytes", 11);
    ASSERT_TRUE(store_->Put(kContainer, "bucket-1", payload, false).ok());
    const auto entry = store_->Get(kContainer, "bucket-1");
    ASSERT_TRUE(entry.ok()) << entry.status();
    EXPECT_EQ(entry->id, "bucket-1");
    EXPECT_EQ(entry->payload, payload);
    const auto stamp = store_->Stat(kContainer, "bucket-1");
    ASSERT_TRUE(stamp.ok());
    EXPECT_EQ(*stamp, entry->stamp);
    EXPECT_EQ(stamp->size, fs::file_size(Containers() / "bucket-1.entry"));
    EXPECT_EQ(Names(Containers()), (Ids{".lock", "bucket-1.entry"}));  // .lock: FolderLock
}

TEST_F(EntryStoreTest, KindsAreSeparateNamespaces) {
    ASSERT_TRUE(store_->Put(kContainer, "x", "container", false).ok());
    ASSERT_TRUE(store_->Put(kCalibration, "x", "calibration", false).ok());
    EXPECT_EQ(store_->Get(kContainer, "x")->payload, "container");
    EXPECT_EQ(store_->Get(kCalibration, "x")->payload, "calibration");
    ASSERT_TRUE(store_->Delete(kCalibration, "x").ok());
    EXPECT_TRUE(store_->Get(kContainer, "x").ok());
}

TEST_F(EntryStoreTest, EmptyPayloadRoundTrips) {
    ASSERT_TRUE(store_->Put(kCalibration, "empty", "", false).ok());
    EXPECT_EQ(store_->Get(kCalibration, "empty")->payload, "");
}

TEST_F(EntryStoreTest, PutWithoutOverwriteKeepsTheOldContent) {
    ASSERT_TRUE(store_->Put(kContainer, "x", "old", false).ok());
    const absl::Status again = store_->Put(kContainer, "x", "new", false);
    EXPECT_EQ(again.code(), absl::StatusCode::kAlreadyExists);
    EXPECT_EQ(again.message(), "container 'x' already exists");
    EXPECT_EQ(store_->Get(kContainer, "x")->payload, "old");
    EXPECT_FALSE(HasTempFile(Containers()));
}

TEST_F(EntryStoreTest, OverwriteReplacesTheContent) {
    ASSERT_TRUE(store_->Put(kContainer, "x", "old", false).ok());
    const FileStamp before = *store_->Stat(kContainer, "x");
    ASSERT_TRUE(store_->Put(kContainer, "x", "new", true).ok());
    EXPECT_EQ(store_->Get(kContainer, "x")->payload, "new");
    EXPECT_NE(*store_->Stat(kContainer, "x"), before);
    ASSERT_TRUE(store_->Put(kContainer, "fresh", "first", true).ok());
    EXPECT_EQ(store_->Get(kContainer, "fresh")->payload, "first");
    EXPECT_EQ(Names(Containers()), (Ids{".lock", "fresh.entry", "x.entry"}));
}

TEST_F(EntryStoreTest, DeleteThenGetIsNotFound) {
    ASSERT_TRUE(store_->Put(kCalibration, "cal", "yaml", false).ok());
    ASSERT_TRUE(store_->Delete(kCalibration, "cal").ok());
    const auto entry = store_->Get(kCalibration, "cal");
    EXPECT_EQ(entry.status().code(), absl::StatusCode::kNotFound);
    EXPECT_EQ(entry.status().message(), "calibration 'cal' not found");
    EXPECT_EQ(store_->Stat(kCalibration, "cal").status().code(), absl::StatusCode::kNotFound);
    EXPECT_EQ(store_->Delete(kCalibration, "cal").code(), absl::StatusCode::kNotFound);
    EXPECT_TRUE(store_->List(kCalibration).empty());
}

TEST_F(EntryStoreTest, BadIdsAreRejectedByEveryCall) {
    for (const std::string& id :
         std::vector<std::string>{"../x", "..", "a/b", "", ".hidden", std::string(65, 'a')}) {
        EXPECT_EQ(store_->Put(kContainer, id, "p", true).code(), absl::StatusCode::kInvalidArgument)
            << id;
        EXPECT_EQ(store_->Get(kContainer, id).status().code(), absl::StatusCode::kInvalidArgument);
        EXPECT_EQ(store_->Stat(kContainer, id).status().code(), absl::StatusCode::kInvalidArgument);
        EXPECT_EQ(store_->Delete(kContainer, id).code(), absl::StatusCode::kInvalidArgument);
    }
    EXPECT_TRUE(HasSubstr(store_->Put(kContainer, "a/b", "p", true).message(), "container id"));
    EXPECT_EQ(Names(dir_.path()), (Ids{"calibrations", "containers"}));
    EXPECT_TRUE(Names(Containers()).empty());
}

TEST_F(EntryStoreTest, PayloadOverOneGibibyteIsInvalidArgument) {
    // Untouched read-only pages: no memory is committed.
    const std::size_t size = kMaxEntryPayloadBytes + 1;
    void* pages =
        ::mmap(nullptr, size, PROT_READ, MAP_PRIVATE | MAP_ANONYMOUS | MAP_NORESERVE, -1, 0);
    ASSERT_NE(pages, MAP_FAILED);
    const absl::Status status =
        store_->Put(kContainer, "huge", std::string_view(static_cast<char*>(pages), size), true);
    ::munmap(pages, size);
    EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
    EXPECT_TRUE(Names(Containers()).empty());
}

TEST_F(EntryStoreTest, ListIgnoresTempFilesDotfilesAndJunk) {
    for (const char* id : {"b", "a", "c.v2"}) {
        ASSERT_TRUE(store_->Put(kContainer, id, id, false).ok());
    }
    for (const char* junk : {".a.123.0123456789abcdef.tmp", ".hidden.entry", "notes.txt",
                             "x.entry.bak", "bad name.entry", "-x.entry", ".entry", "entry"}) {
        WriteFile(Containers() / junk, "junk");
    }
    fs::create_directory(Containers() / "subdir");
    EXPECT_EQ(store_->List(kContainer), (Ids{"a", "b", "c.v2"}));
    EXPECT_TRUE(store_->List(kCalibration).empty());
}

TEST_F(EntryStoreTest, DamagedEntryFailsAloneAndStaysListed) {
    for (const char* id : {"a", "b", "c", "d"}) {
        ASSERT_TRUE(store_->Put(kContainer, id, std::string(100, id[0]), false).ok());
    }
    std::string b = ReadFile(Containers() / "b.entry");
    b[50] ^= 0x10;
    WriteFile(Containers() / "b.entry", b);
    const std::string c = ReadFile(Containers() / "c.entry");
    WriteFile(Containers() / "c.entry", c.substr(0, c.size() / 2));
    WriteFile(Containers() / "d.entry", "");

    EXPECT_EQ(store_->List(kContainer), (Ids{"a", "b", "c", "d"}));
    const auto damaged = store_->Get(kContainer, "b");
    EXPECT_EQ(damaged.status().code(), absl::StatusCode::kDataLoss);
    EXPECT_TRUE(HasSubstr(damaged.status().message(), "container 'b': checksum mismatch"));
    EXPECT_EQ(store_->Get(kContainer, "c").status().code(), absl::StatusCode::kDataLoss);
    EXPECT_TRUE(HasSubstr(store_->Get(kContainer, "d").status().message(), "container 'd': "));
    EXPECT_EQ(store_->Get(kContainer, "a")->payload, std::string(100, 'a'));
    // A damaged entry can be replaced or deleted.
    EXPECT_TRUE(store_->Put(kContainer, "b", "repaired", true).ok());
    EXPECT_EQ(store_->Get(kContainer, "b")->payload, "repaired");
    EXPECT_TRUE(store_->Delete(kContainer, "c").ok());
}

TEST_F(EntryStoreTest, OtherSchemaVersionAndOtherKindAreReported) {
    ASSERT_TRUE(store_->Put(kContainer, "v", "payload", false).ok());
    std::string file = ReadFile(Containers() / "v.entry");
    file[8] = 9;
    WriteFile(Containers() / "v.entry", file);
    const auto future = store_->Get(kContainer, "v");
    EXPECT_EQ(future.status().code(), absl::StatusCode::kFailedPrecondition);
    EXPECT_TRUE(HasSubstr(future.status().message(), "container 'v': entry schema version 9"));
    // A calibration file copied into the containers folder.
    ASSERT_TRUE(store_->Put(kCalibration, "cal", "yaml", false).ok());
    fs::copy_file(dir_.path() / "calibrations" / "cal.entry", Containers() / "cal.entry");
    EXPECT_EQ(store_->Get(kContainer, "cal").status().code(), absl::StatusCode::kDataLoss);
}

TEST_F(EntryStoreTest, NonRegularAndOversizedFilesAreDataLoss) {
    fs::create_directory(Containers() / "dir.entry");
    const auto dir = store_->Get(kContainer, "dir");
    EXPECT_EQ(dir.status().code(), absl::StatusCode::kDataLoss);
    EXPECT_TRUE(HasSubstr(dir.status().message(), "not a regular file"));
    ASSERT_EQ(::mkfifo((Containers() / "fifo.entry").c_str(), 0644), 0);
    EXPECT_EQ(store_->Get(kContainer, "fifo").status().code(), absl::StatusCode::kDataLoss);
    // A sparse 2 GiB file: refused before anything is allocated.
    { std::ofstream touch(Containers() / "big.entry"); }
    fs::resize_file(Containers() / "big.entry", uint64_t{2} << 30);
    const auto big = store_->Get(kContainer, "big");
    EXPECT_EQ(big.status().code(), absl::StatusCode::kDataLoss);
    EXPECT_TRUE(HasSubstr(big.status().message(), "more than the limit"));
}

TEST_F(EntryStoreTest, OpenRemovesStaleTempFilesAndKeepsFreshOnes) {
    const fs::path stale = Containers() / ".x.4242.00000000deadbeef.tmp";
    const fs::path fresh = Containers() / ".x.4243.00000000deadbeef.tmp";
    const fs::path stale_calibration = dir_.path() / "calibrations" / ".c.1.0123456789abcdef.tmp";
    const fs::path foreign = Containers() / ".other.tmp";
    for (const fs::path& p : {stale, fresh, stale_calibration, foreign}) WriteFile(p, "partial");
    SetAge(stale, std::chrono::hours(2));
    SetAge(stale_calibration, std::chrono::hours(2));
    SetAge(foreign, std::chrono::hours(2));
    ASSERT_TRUE(EntryStore::Open(dir_.path()).ok());
    EXPECT_FALSE(fs::exists(stale));
    EXPECT_FALSE(fs::exists(stale_calibration));
    EXPECT_TRUE(fs::exists(fresh));
    EXPECT_TRUE(fs::exists(foreign));  // not a name this store writes
    EntryStoreConfig config;
    config.stale_temp_age = std::chrono::seconds(0);
    ASSERT_TRUE(EntryStore::Open(dir_.path(), config).ok());
    EXPECT_FALSE(fs::exists(fresh));
}

TEST_F(EntryStoreTest, CheckWritableLeavesNothingBehind) {
    EXPECT_TRUE(store_->CheckWritable().ok());
    EXPECT_TRUE(Names(Containers()).empty());
    EXPECT_TRUE(Names(dir_.path() / "calibrations").empty());
}

// Two store objects on one root model two server processes sharing the data directory.
TEST_F(EntryStoreTest, TwoStoresSeeEachOthersWritesAndDeletes) {
    auto other = EntryStore::Open(dir_.path());
    ASSERT_TRUE(other.ok());
    EntryStore& b = **other;
    ASSERT_TRUE(store_->Put(kContainer, "shared", "v1", false).ok());
    EXPECT_EQ(b.Get(kContainer, "shared")->payload, "v1");
    EXPECT_EQ(b.List(kContainer), Ids{"shared"});
    EXPECT_EQ(b.Put(kContainer, "shared", "v2", false).code(), absl::StatusCode::kAlreadyExists);
    ASSERT_TRUE(b.Put(kContainer, "shared", "v2", true).ok());
    EXPECT_EQ(store_->Get(kContainer, "shared")->payload, "v2");
    ASSERT_TRUE(b.Delete(kContainer, "shared").ok());
    EXPECT_EQ(store_->Get(kContainer, "shared").status().code(), absl::StatusCode::kNotFound);
    EXPECT_TRUE(store_->List(kContainer).empty());
}

// Runs `write(i)` on `n` threads released together; the index of the one that succeeded, -1
// when none did. Every other must fail with `lost`; two winners fail the test.
int OneWinnerAmongThreads(int n, absl::StatusCode lost,
                          const std::function<absl::Status(int)>& write) {
    std::atomic<int> ready{0};
    std::vector<absl::Status> results(static_cast<std::size_t>(n));
    std::vector<std::thread> threads;
    for (int t = 0; t < n; ++t) {
        threads.emplace_back([&, t] {
            ++ready;
            while (ready.load() < n) std::this_thread::yield();
            results[static_cast<std::size_t>(t)] = write(t);
        });
    }
    for (std::thread& t : threads) t.join();
    int winner = -1;
    for (int t = 0; t < n; ++t) {
        const absl::Status& result = results[static_cast<std::size_t>(t)];
        if (result.ok()) {
            EXPECT_EQ(winner, -1) << "two winners";
            winner = t;
        } else {
            EXPECT_EQ(result.code(), lost) << result;
        }
    }
    return winner;
}

// Runs `write(i)` in `n` forked processes (each opening the store itself, as a replica would);
// how many succeeded. A process whose write fails otherwise than with `lost` fails the test.
int WinnersAmongProcesses(const fs::path& root, int n, absl::StatusCode lost,
                          const std::function<absl::Status(EntryStore&, int)>& write) {
    constexpr int kWon = 10;
    constexpr int kLost = 11;
    std::vector<pid_t> children;
    for (int p = 0; p < n; ++p) {
        const pid_t pid = ::fork();
        if (pid < 0) ADD_FAILURE() << "fork failed";
        if (pid == 0) {
            auto store = EntryStore::Open(root);
            if (!store.ok()) ::_exit(1);
            const absl::Status s = write(**store, p);
            ::_exit(s.ok() ? kWon : s.code() == lost ? kLost : 1);
        }
        children.push_back(pid);
    }
    int won = 0;
    for (const pid_t pid : children) {
        int status = 0;
        EXPECT_EQ(::waitpid(pid, &status, 0), pid);
        EXPECT_TRUE(WIFEXITED(status));
        EXPECT_NE(WEXITSTATUS(status), 1) << "a write failed otherwise";
        won += WEXITSTATUS(status) == kWon;
    }
    return won;
}

TEST_F(EntryStoreTest, RacingThreadsCreateExactlyOnce) {
    for (int round = 0; round < 20; ++round) {
        const std::string id = "race" + std::to_string(round);
        const int winner = OneWinnerAmongThreads(8, absl::StatusCode::kAlreadyExists, [&](int t) {
            return store_->Put(kContainer, id, std::string(4096, static_cast<char>('a' + t)),
                               false);
        });
        ASSERT_NE(winner, -1) << "round " << round;
        EXPECT_EQ(store_->Get(kContainer, id)->payload,
                  std::string(4096, static_cast<char>('a' + winner)));
    }
    EXPECT_FALSE(HasTempFile(Containers()));
}

TEST_F(EntryStoreTest, RacingProcessesCreateExactlyOnce) {
    for (int round = 0; round < 5; ++round) {
        const std::string id = "proc" + std::to_string(round);
        EXPECT_EQ(WinnersAmongProcesses(dir_.path(), 4, absl::StatusCode::kAlreadyExists,
                                        [&](EntryStore& store, int) {
                                            return store.Put(kContainer, id,
                                                             std::string(1 << 16, 'p'), false);
                                        }),
                  1)
            << "round " << round;
    }
    EXPECT_FALSE(HasTempFile(Containers()));
}
// The precondition of a compare-and-swap: the entry published now must hold `payload`.
EntryStore::Precondition Holds(const std::string& payload) {
    return [payload](const absl::StatusOr<StoredEntry>& current) -> absl::Status {
        if (!current.ok()) return current.status();
        return current->payload == payload ? absl::OkStatus()
                                           : absl::AbortedError("the entry changed");
    };
}

TEST_F(EntryStoreTest, PutIfWritesOnlyWhatThePreconditionAccepts) {
    ASSERT_TRUE(store_->Put(kContainer, "cas", "v1", false).ok());
    EXPECT_EQ(store_->PutIf(kContainer, "cas", "v2", Holds("v0")).code(),
              absl::StatusCode::kAborted);
    EXPECT_EQ(store_->Get(kContainer, "cas")->payload, "v1");
    EXPECT_TRUE(store_->PutIf(kContainer, "cas", "v2", Holds("v1")).ok());
    EXPECT_EQ(store_->Get(kContainer, "cas")->payload, "v2");
    EXPECT_EQ(store_->PutIf(kContainer, "absent", "v1", Holds("v0")).code(),
              absl::StatusCode::kNotFound);
    EXPECT_EQ(store_->DeleteIf(kContainer, "cas", Holds("v1")).code(), absl::StatusCode::kAborted);
    EXPECT_TRUE(store_->DeleteIf(kContainer, "cas", Holds("v2")).ok());
    EXPECT_EQ(store_->Get(kContainer, "cas").status().code(), absl::StatusCode::kNotFound);
    EXPECT_FALSE(HasTempFile(Containers()));
    EXPECT_EQ(store_->List(kContainer), Ids{});  // the lock file is no entry
}

// Writers that all read version N and write N+1 conditionally: exactly one per version wins
// (no lost update).
TEST_F(EntryStoreTest, RacingThreadsCompareAndSwapExactlyOnce) {
    ASSERT_TRUE(store_->Put(kContainer, "cas", "v0", false).ok());
    for (int round = 0; round < 20; ++round) {
        const std::string before = "v" + std::to_string(round);
        const auto version = [&](int t) {
            return "v" + std::to_string(round + 1) + "." + std::to_string(t);
        };
        const int winner = OneWinnerAmongThreads(8, absl::StatusCode::kAborted, [&](int t) {
            return store_->PutIf(kContainer, "cas", version(t), Holds(before));
        });
        ASSERT_NE(winner, -1) << "round " << round;
        ASSERT_EQ(store_->Get(kContainer, "cas")->payload, version(winner));
        ASSERT_TRUE(store_->Put(kContainer, "cas", "v" + std::to_string(round + 1), true).ok());
    }
    EXPECT_FALSE(HasTempFile(Containers()));
}

// The same across processes sharing the root, as replicas on one volume do.
TEST_F(EntryStoreTest, RacingProcessesCompareAndSwapExactlyOnce) {
    for (int round = 0; round < 5; ++round) {
        const std::string id = "proc" + std::to_string(round);
        ASSERT_TRUE(store_->Put(kContainer, id, "old", false).ok());
        EXPECT_EQ(WinnersAmongProcesses(dir_.path(), 4, absl::StatusCode::kAborted,
                                        [&](EntryStore& store, int p) {
                                            return store.PutIf(
                                                kContainer, id,
                                                std::string(1 << 16, static_cast<char>('a' + p)),
                                                Holds("old"));
                                        }),
                  1)
            << "round " << round;
    }
    EXPECT_FALSE(HasTempFile(Containers()));
}

TEST_F(EntryStoreTest, FailedWriteRemovesItsTempFile) {
    // In a child: a file size limit makes write(2) fail with EFBIG part-way.
    const pid_t pid = ::fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
        ::signal(SIGXFSZ, SIG_IGN);
        const rlimit limit{4096, 4096};
        ::setrlimit(RLIMIT_FSIZE, &limit);
        const absl::Status s = store_->Put(kContainer, "x", std::string(1 << 20, 'x'), true);
        const bool io_error =
            s.code() == absl::StatusCode::kInternal || s.code() == absl::StatusCode::kUnavailable;
        ::_exit(io_error && HasSubstr(s.message(), "File too large") ? 0 : 1);
    }
    int status = 0;
    ASSERT_EQ(::waitpid(pid, &status, 0), pid);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
    EXPECT_TRUE(Names(Containers()).empty());
}

// A writer killed at any moment leaves no entry or a complete one, never a partial one.
TEST_F(EntryStoreTest, KilledWriterLeavesNoPartialEntry) {
    constexpr std::size_t kPayloadBytes = 8 << 20;
    // One write takes some 30-50 ms here; the kills land before, during and between writes.
    std::mt19937 rng(17);
    std::uniform_int_distribution<int> delay_us(0, 150'000);
    for (int round = 0; round < 20; ++round) {
        if (round % 4 == 0) (void)store_->Delete(kContainer, "big");
        const pid_t pid = ::fork();
        ASSERT_GE(pid, 0);
        if (pid == 0) {
            for (int i = 0;; ++i) {
                const std::string payload(kPayloadBytes, static_cast<char>('a' + i % 26));
                if (!store_->Put(kContainer, "big", payload, true).ok()) ::_exit(1);
            }
        }
        std::this_thread::sleep_for(std::chrono::microseconds(delay_us(rng)));
        ::kill(pid, SIGKILL);
        int status = 0;
        ASSERT_EQ(::waitpid(pid, &status, 0), pid);
        ASSERT_TRUE(WIFSIGNALED(status)) << "the writer failed on its own";

        const auto entry = store_->Get(kContainer, "big");
        if (!entry.ok()) {
            EXPECT_EQ(entry.status().code(), absl::StatusCode::kNotFound) << entry.status();
            EXPECT_TRUE(store_->List(kContainer).empty());
            continue;
        }
        ASSERT_EQ(entry->payload.size(), kPayloadBytes);
        const char first = entry->payload[0];
        EXPECT_EQ(entry->payload.find_first_not_of(first), std::string::npos) << round;
        EXPECT_EQ(store_->List(kContainer), Ids{"big"});
    }
    // Whatever temp files the kills left are swept by the next Open once stale.
    EntryStoreConfig config;
    config.stale_temp_age = std::chrono::seconds(0);
    ASSERT_TRUE(EntryStore::Open(dir_.path(), config).ok());
    EXPECT_FALSE(HasTempFile(Containers()));
}

}  // namespace
}  // namespace soilvol::server
