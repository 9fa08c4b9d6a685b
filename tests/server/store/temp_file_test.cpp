#include "server/store/temp_file.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <string>

#include "tests/server/store/scratch_dir.hpp"

namespace soilvol::server {
namespace {

TEST(TempFileTest, TempNamesAreRecognisedAndDistinct) {
    std::set<std::string> names;
    for (const char* id : {"a", "c.v2", "x-y_z", "7"}) {
        for (int i = 0; i < 250; ++i) {
            const std::string name = TempName(id);
            EXPECT_TRUE(IsTempName(name)) << name;
            EXPECT_EQ(name.rfind(std::string(".") + id + ".", 0), 0u) << name;
            names.insert(name);
        }
    }
    EXPECT_EQ(names.size(), 1000u);
}

TEST(TempFileTest, OtherNamesAreNotTempNames) {
    for (const char* name :
         {"", ".tmp", "..tmp", ".a.tmp", ".a.1.tmp", ".a.12.0123456789abcde.tmp",
          ".a.x1.0123456789abcdef.tmp", ".a..0123456789abcdef.tmp", "a.1.0123456789abcdef.tmp",
          "..1.0123456789abcdef.tmp", "...1.0123456789abcdef.tmp", ".-a.1.0123456789abcdef.tmp",
          ".a.1.0123456789abcdef.tmpx", ".a.1.0123456789abcdef", "a.entry", ".other.tmp"}) {
        EXPECT_FALSE(IsTempName(name)) << name;
    }
    EXPECT_TRUE(IsTempName(".a.1.0123456789abcdef.tmp"));
    EXPECT_TRUE(IsTempName(".a.b.c.99.0123456789abcdef.tmp"));
}

TEST(TempFileTest, WriteTempFileWritesThePiecesInOrder) {
    ScratchDir dir;
    const auto path = WriteTempFile(dir.path().string(), "x", {"head", "", "body", "tail"});
    ASSERT_TRUE(path.ok()) << path.status();
    EXPECT_EQ(std::filesystem::path(*path).parent_path(), dir.path());
    EXPECT_TRUE(IsTempName(std::filesystem::path(*path).filename().string()));
    std::ifstream in(*path, std::ios::binary);
    std::string content(12, '\0');
    in.read(content.data(), 12);
    EXPECT_EQ(content, "headbodytail");
    EXPECT_EQ(std::filesystem::file_size(*path), 12u);
}

TEST(TempFileTest, MissingFolderIsAnErrorWithTheErrnoText) {
    ScratchDir dir;
    const auto path = WriteTempFile((dir.path() / "missing").string(), "x", {"bytes"});
    EXPECT_EQ(path.status().code(), absl::StatusCode::kInternal);
    EXPECT_NE(path.status().message().find("No such file or directory"), absl::string_view::npos)
        << path.status();
}

TEST(TempFileTest, OnlyStaleRegularTempFilesAreRemoved) {
    ScratchDir dir;
    const std::filesystem::path folder = dir.path();
    std::ofstream(folder / ".a.1.0123456789abcdef.tmp") << "partial";
    std::ofstream(folder / "a.entry") << "entry";
    std::filesystem::create_directory(folder / ".b.2.0123456789abcdef.tmp");
    RemoveStaleTempFiles(folder.string(), std::chrono::hours(1));
    EXPECT_TRUE(std::filesystem::exists(folder / ".a.1.0123456789abcdef.tmp"));
    RemoveStaleTempFiles(folder.string(), std::chrono::seconds(0));
    EXPECT_FALSE(std::filesystem::exists(folder / ".a.1.0123456789abcdef.tmp"));
    EXPECT_TRUE(std::filesystem::exists(folder / "a.entry"));
    EXPECT_TRUE(std::filesystem::is_directory(folder / ".b.2.0123456789abcdef.tmp"));
}

}  // namespace
}  // namespace soilvol::server
