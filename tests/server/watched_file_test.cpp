#include "server/base/watched_file.hpp"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include "tests/server/store/scratch_dir.hpp"

namespace soilvol::server {
namespace {

namespace fs = std::filesystem;
using std::chrono::milliseconds;

void Write(const fs::path& path, const std::string& text) {
    std::ofstream(path, std::ios::trunc) << text;
}

// The way cert-manager and kubelet rotate a mounted secret: a new file renamed over the old.
void ReplaceByRename(const fs::path& path, const std::string& text) {
    const fs::path next = path.string() + ".next";
    Write(next, text);
    fs::rename(next, path);
}

class WatchedFilesTest : public ::testing::Test {
  protected:
    fs::path File(const std::string& name, const std::string& text) {
        const fs::path path = dir_.path() / name;
        Write(path, text);
        return path;
    }
    ScratchDir dir_;
};

TEST_F(WatchedFilesTest, UnchangedFilesAreNotChanged) {
    WatchedFiles watched({File("cert.pem", "a"), File("key.pem", "b")}, milliseconds(0));
    EXPECT_FALSE(watched.Changed());
    EXPECT_FALSE(watched.Changed());
}

TEST_F(WatchedFilesTest, AnEditARenameOrARemovalIsAChangeUntilMarked) {
    const fs::path cert = File("cert.pem", "first");
    const fs::path key = File("key.pem", "key");
    WatchedFiles watched({cert.string(), key.string()}, milliseconds(0));
    Write(cert, "second, longer");  // size differs: no reliance on the mtime's granularity
    EXPECT_TRUE(watched.Changed());
    EXPECT_TRUE(watched.Changed()) << "still changed until Mark";
    watched.Mark();
    EXPECT_FALSE(watched.Changed());
    ReplaceByRename(key, "key");  // same size and maybe the same mtime: a new inode
    EXPECT_TRUE(watched.Changed());
    watched.Mark();
    fs::remove(key);
    EXPECT_TRUE(watched.Changed());
    watched.Mark();
    EXPECT_FALSE(watched.Changed()) << "a missing file stays missing";
    Write(key, "back");
    EXPECT_TRUE(watched.Changed());
}

TEST_F(WatchedFilesTest, FilesAreLookedAtNoMoreThanOncePerPeriod) {
    const fs::path cert = File("cert.pem", "first");
    WatchedFiles watched({cert.string()}, milliseconds(300));
    Write(cert, "second, longer");
    EXPECT_FALSE(watched.Changed()) << "within the period of the construction";
    std::this_thread::sleep_for(milliseconds(350));
    EXPECT_TRUE(watched.Changed());
    EXPECT_FALSE(watched.Changed()) << "looked at a moment ago";
}

TEST_F(WatchedFilesTest, AnEmptyPathIsWatchedAsMissing) {
    WatchedFiles watched({"", File("cert.pem", "a").string()}, milliseconds(0));
    EXPECT_FALSE(watched.Changed());
}

TEST_F(WatchedFilesTest, ReadSmallFileReadsUpToItsLimit) {
    const fs::path path = File("tokens", "abc\n");
    const auto text = ReadSmallFile(path.string(), 4, "auth-tokens-file");
    ASSERT_TRUE(text.ok()) << text.status();
    EXPECT_EQ(*text, "abc\n");
}

TEST_F(WatchedFilesTest, ReadSmallFileRefusesNamingTheFlag) {
    const fs::path big = File("big", std::string(5, 'x'));
    const auto too_big = ReadSmallFile(big.string(), 4, "auth-tokens-file");
    EXPECT_EQ(too_big.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(too_big.status().message().find("--auth-tokens-file"), std::string::npos);
    EXPECT_NE(too_big.status().message().find("larger than 4 bytes"), std::string::npos);
    const auto missing = ReadSmallFile((dir_.path() / "none").string(), 4, "tls-cert");
    EXPECT_EQ(missing.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(missing.status().message().find("cannot open"), std::string::npos);
    const auto folder = ReadSmallFile(dir_.path().string(), 4, "tls-cert");
    EXPECT_EQ(folder.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(folder.status().message().find("not a regular file"), std::string::npos);
    const fs::path fifo = dir_.path() / "fifo";
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    // A FIFO blocks an open for reading until a writer comes: refused at once instead.
    const auto pipe = ReadSmallFile(fifo.string(), 4, "tls-cert");
    EXPECT_EQ(pipe.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(pipe.status().message().find("not a regular file"), std::string::npos);
    const fs::path link = dir_.path() / "link";
    fs::create_symlink(big, link);
    EXPECT_EQ(ReadSmallFile(link.string(), 4, "tls-cert").status().code(),
              absl::StatusCode::kInvalidArgument)
        << "a symlink to a large file is still too large";
}

}  // namespace
}  // namespace soilvol::server
