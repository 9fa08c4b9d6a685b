#include "client/input_files.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace soilvol::client {
namespace {

namespace fs = std::filesystem;

class TempDir {
  public:
    explicit TempDir(const std::string& name)
        : path_(fs::temp_directory_path() / (name + "-" + std::to_string(::getpid()))) {
        fs::remove_all(path_);
        fs::create_directories(path_);
    }
    ~TempDir() { fs::remove_all(path_); }
    std::string Touch(const std::string& name, const std::string& content = "x") const {
        std::ofstream(path_ / name, std::ios::binary) << content;
        return (path_ / name).string();
    }
    std::string path() const { return path_.string(); }

  private:
    fs::path path_;
};

TEST(ParseTuples, ReadsFourPointsWithSpaces) {
    const auto points = ParseTuples(" 1,2,3; 4, 5 ,6;-7,8e-1,9 ;0,0,0", 3, 4, "--corners");
    ASSERT_TRUE(points.ok()) << points.status();
    EXPECT_EQ((*points)[1], (std::vector<double>{4, 5, 6}));
    EXPECT_EQ((*points)[2], (std::vector<double>{-7, 0.8, 9}));
}

TEST(ParseTuples, HostileInputNamesTheFlag) {
    for (const char* text :
         {"", "1,2;3,4;5,6", "1,2;3,4;5,6;7,8;9,10", "1,2;3,4;5,6;7", "1,2;3,4;5,6;7,8,9",
          "1,2;3,x;5,6;7,8", "1,2;3,nan;5,6;7,8", "1,2;3,inf;5,6;7,8", "1,,2;3,4;5,6;7,8"}) {
        const auto points = ParseTuples(text, 2, 4, "--pixel-corners");
        EXPECT_TRUE(absl::IsInvalidArgument(points.status())) << text;
        EXPECT_NE(points.status().message().find("--pixel-corners"), absl::string_view::npos);
    }
}

TEST(ParsePose, PositionAndQuaternionOrPositionAlone) {
    const auto pose = ParsePose("0.5, -1, 2.5; 0.7071068,0,0, 0.7071068", "--container-pose");
    ASSERT_TRUE(pose.ok()) << pose.status();
    EXPECT_EQ(pose->position_m, (std::array<double, 3>{0.5, -1.0, 2.5}));
    EXPECT_DOUBLE_EQ(pose->quaternion[3], 0.7071068);
    const auto plain = ParsePose("1,2,3", "--container-pose");
    ASSERT_TRUE(plain.ok()) << plain.status();
    EXPECT_EQ(plain->quaternion, (std::array<double, 4>{1.0, 0.0, 0.0, 0.0}));
}

TEST(ParsePose, HostileInputNamesTheFlag) {
    for (const char* text : {"", "1,2", "1,2,3;1,0,0", "1,2,3;1,0,0,0;1", "1,2,3;2,0,0,0",
                             "1,2,nan", "1,2,3;0,0,0,0", "x,y,z;1,0,0,0", "1,2,3;1,0,0,inf"}) {
        const auto pose = ParsePose(text, "--container-pose");
        EXPECT_TRUE(absl::IsInvalidArgument(pose.status())) << text;
        EXPECT_NE(pose.status().message().find("--container-pose"), absl::string_view::npos)
            << pose.status();
    }
}

TEST(FindChessboardPairs, PairsBySuffixAndReportsTheRest) {
    const TempDir dir("soilvol-pairs");
    const std::string left01 = dir.Touch("left01.jpg");
    const std::string right01 = dir.Touch("right01.png");
    const std::string left02 = dir.Touch("left02.JPEG");
    const std::string right02 = dir.Touch("right02.jpg");
    const std::string left03 = dir.Touch("left03.png");
    const std::string right04 = dir.Touch("right04.png");
    dir.Touch("left05.bmp");
    dir.Touch("right05.bmp");
    dir.Touch("notes.txt");
    std::vector<std::string> unpaired;
    const auto pairs = FindChessboardPairs(dir.path(), &unpaired);
    ASSERT_TRUE(pairs.ok()) << pairs.status();
    ASSERT_EQ(pairs->size(), 2u);
    EXPECT_EQ((*pairs)[0].left, left01);
    EXPECT_EQ((*pairs)[0].right, right01);
    EXPECT_EQ((*pairs)[1].left, left02);
    EXPECT_EQ((*pairs)[1].right, right02);
    EXPECT_EQ(unpaired, (std::vector<std::string>{left03, right04}));
}

TEST(FindChessboardPairs, EmptyOrMissingFolderIsInvalid) {
    const TempDir dir("soilvol-nopairs");
    dir.Touch("left01.png");
    EXPECT_TRUE(absl::IsInvalidArgument(FindChessboardPairs(dir.path(), nullptr).status()));
    const auto missing = FindChessboardPairs(dir.path() + "/missing", nullptr);
    EXPECT_TRUE(absl::IsInvalidArgument(missing.status()));
    EXPECT_NE(missing.status().message().find("missing"), absl::string_view::npos);
}

TEST(ReadFile, KeepsBinaryContentAndNamesUnreadableFiles) {
    const TempDir dir("soilvol-read");
    const std::string binary("ply\0\xff\n", 6);
    EXPECT_EQ(*ReadFile(dir.Touch("scan.ply", binary)), binary);
    const std::string big(3 << 20, 'a');
    EXPECT_EQ(ReadFile(dir.Touch("big.ply", big))->size(), big.size());
    for (const std::string& path : {dir.path() + "/none.ply", dir.path()}) {
        const auto content = ReadFile(path);
        EXPECT_TRUE(absl::IsInvalidArgument(content.status()));
        EXPECT_NE(content.status().message().find(path), absl::string_view::npos);
    }
}

}  // namespace
}  // namespace soilvol::client
