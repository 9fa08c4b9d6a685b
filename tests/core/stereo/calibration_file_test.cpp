#include "core/stereo/calibration_file.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <chrono>
#include <random>
#include <string>
#include <vector>

#include "tests/core/stereo/stereo_test_util.hpp"

namespace soilvol::stereo {
namespace {

using test::IsInvalidWith;

StereoParameters SyntheticRig() {
    StereoParameters rig;
    rig.image_width = 1280;
    rig.image_height = 720;
    rig.left = {900.5, 901.25, 640.3, 359.7, {-0.05, 0.01, 0.0002, -0.0001, 0.001}};
    rig.right = {902.0, 902.75, 637.9, 362.1, {}};
    rig.R_right_left =
        Eigen::AngleAxisd(0.015, Eigen::Vector3d(0.1, 1.0, -0.2).normalized()).toRotationMatrix();
    rig.t_right_left_m = -rig.R_right_left * Eigen::Vector3d(0.12, 0.001, -0.002);
    return rig;
}

StereoCalibration ParametersCalibration() {
    auto calibration = CalibrationFromParameters(SyntheticRig());
    EXPECT_TRUE(calibration.ok()) << calibration.status();
    return *calibration;
}

// A chessboard-sourced calibration with figures, pairs and skipped entries, without running
// the detector: the file layer only cares about the values.
StereoCalibration ChessboardLikeCalibration() {
    StereoCalibration calibration = ParametersCalibration();
    calibration.source = "chessboard";
    calibration.rms_reprojection_px = 0.1984;
    calibration.mean_epipolar_px = 0.1091;
    calibration.pairs = {{0, 0.203, 0.124}, {2, 0.192, 0.088}, {3, 0.285, 0.173}};
    calibration.skipped = {{1, "left: chessboard 9x6 not found"},
                           {4, "right: not a \"decodable\" image [x] {y} # - : '"}};
    return calibration;
}

void ExpectSame(const StereoCalibration& actual, const StereoCalibration& expected) {
    const StereoParameters& a = actual.parameters;
    const StereoParameters& e = expected.parameters;
    EXPECT_EQ(a.image_width, e.image_width);
    EXPECT_EQ(a.image_height, e.image_height);
    for (const auto& [x, y] : {std::pair{&a.left, &e.left}, std::pair{&a.right, &e.right}}) {
        EXPECT_EQ(x->fx, y->fx);
        EXPECT_EQ(x->fy, y->fy);
        EXPECT_EQ(x->cx, y->cx);
        EXPECT_EQ(x->cy, y->cy);
        EXPECT_EQ(x->distortion, y->distortion);
    }
    EXPECT_EQ(a.R_right_left, e.R_right_left);
    EXPECT_EQ(a.t_right_left_m, e.t_right_left_m);
    EXPECT_EQ(actual.R1, expected.R1);
    EXPECT_EQ(actual.R2, expected.R2);
    EXPECT_EQ(actual.P1, expected.P1);
    EXPECT_EQ(actual.P2, expected.P2);
    EXPECT_EQ(actual.Q, expected.Q);
    EXPECT_EQ(actual.baseline_m, expected.baseline_m);
    EXPECT_EQ(actual.focal_px, expected.focal_px);
    EXPECT_EQ(actual.rms_reprojection_px, expected.rms_reprojection_px);
    EXPECT_EQ(actual.mean_epipolar_px, expected.mean_epipolar_px);
    EXPECT_EQ(actual.source, expected.source);
    ASSERT_EQ(actual.pairs.size(), expected.pairs.size());
    for (std::size_t i = 0; i < actual.pairs.size(); ++i) {
        EXPECT_EQ(actual.pairs[i].index, expected.pairs[i].index);
        EXPECT_EQ(actual.pairs[i].rms_px, expected.pairs[i].rms_px);
        EXPECT_EQ(actual.pairs[i].epipolar_px, expected.pairs[i].epipolar_px);
    }
    ASSERT_EQ(actual.skipped.size(), expected.skipped.size());
    for (std::size_t i = 0; i < actual.skipped.size(); ++i) {
        EXPECT_EQ(actual.skipped[i].index, expected.skipped[i].index);
        EXPECT_EQ(actual.skipped[i].reason, expected.skipped[i].reason);
    }
}

// `yaml` with the first occurrence of `from` replaced by `to`.
std::string Replaced(std::string yaml, const std::string& from, const std::string& to) {
    const std::size_t at = yaml.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) yaml.replace(at, from.size(), to);
    return yaml;
}

// Found by fuzz_calibration_file: 40 bytes with a NUL and 0xFF bytes kept OpenCV 4.6's YAML
// parser looping forever. Files are printable ASCII; anything else is refused unparsed.
TEST(CalibrationFileHostileTest, BytesPastPrintableAsciiAreRefusedBeforeOpenCvParses) {
    const std::string hang(
        "%YAML:1.0\n---z\xac"
        "ersion: 2\ns-2\n-e:\0\xff\xff\xff\xff\xff.\n",
        40);
    const auto parsed = ParseCalibration(hang);
    ASSERT_FALSE(parsed.ok());
    EXPECT_EQ(parsed.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(parsed.status().message().find("is not printable ASCII"), std::string::npos)
        << parsed.status();
}

TEST(CalibrationFileTest, ParametersCalibrationRoundTripsExactly) {
    const StereoCalibration calibration = ParametersCalibration();
    const auto parsed = ParseCalibration(SerializeCalibration(calibration));
    ASSERT_TRUE(parsed.ok()) << parsed.status();
    ExpectSame(*parsed, calibration);
}

TEST(CalibrationFileTest, ChessboardCalibrationRoundTripsExactly) {
    const StereoCalibration calibration = ChessboardLikeCalibration();
    const auto parsed = ParseCalibration(SerializeCalibration(calibration));
    ASSERT_TRUE(parsed.ok()) << parsed.status();
    ExpectSame(*parsed, calibration);
}

TEST(CalibrationFileTest, RealChessboardCalibrationRoundTripsExactly) {
    const std::vector<ImagePair> pairs = test::SamplePairs();
    if (pairs.empty()) GTEST_SKIP() << "opencv-doc sample pairs not installed";
    const std::vector<ImagePair> six(pairs.begin(), pairs.begin() + 6);
    const auto calibration = CalibrateFromChessboards(six, {9, 6, 0.025});
    ASSERT_TRUE(calibration.ok()) << calibration.status();
    const auto parsed = ParseCalibration(SerializeCalibration(*calibration));
    ASSERT_TRUE(parsed.ok()) << parsed.status();
    ExpectSame(*parsed, *calibration);
}

TEST(CalibrationFileTest, FileIsReadableYamlWithEveryKey) {
    const std::string yaml = SerializeCalibration(ChessboardLikeCalibration());
    EXPECT_EQ(yaml.rfind("%YAML:1.0", 0), 0u);
    for (const char* key : {"version: 1",
                            "source: chessboard",
                            "image_width: 1280",
                            "image_height: 720",
                            "left:",
                            "right:",
                            "fx:",
                            "distortion:",
                            "R: !!opencv-matrix",
                            "T: !!opencv-matrix",
                            "R1:",
                            "R2:",
                            "P1:",
                            "P2:",
                            "Q:",
                            "baseline_m:",
                            "focal_px:",
                            "rms_reprojection_px:",
                            "mean_epipolar_px:",
                            "pairs:",
                            "skipped:",
                            "left: chessboard 9x6 not found"}) {
        EXPECT_NE(yaml.find(key), std::string::npos) << key;
    }
}

TEST(CalibrationFileTest, OtherVersionsAreRefused) {
    const std::string yaml = SerializeCalibration(ParametersCalibration());
    EXPECT_TRUE(IsInvalidWith(ParseCalibration(Replaced(yaml, "version: 1", "version: 2")),
                              "version 2 is not supported (expected 1)"));
    EXPECT_TRUE(IsInvalidWith(ParseCalibration(Replaced(yaml, "version: 1", "version: one")),
                              "'version' must be an integer"));
    EXPECT_TRUE(IsInvalidWith(ParseCalibration(Replaced(yaml, "version: 1", "vers: 1")),
                              "missing key 'version'"));
}

TEST(CalibrationFileTest, HostileTextIsInvalidArgument) {
    std::mt19937 rng(5);
    std::string random_bytes(4096, '\0');
    for (char& c : random_bytes) c = static_cast<char>(rng());
    const std::string deep = std::string(200000, '[') + std::string(200000, ']');
    std::string dashes = "%YAML:1.0\n---\na: ";
    for (int i = 0; i < 100000; ++i) dashes += "- ";
    const std::string inputs[] = {
        "",
        random_bytes,
        "%YAML:1.0\n" + random_bytes,
        "%YAML:1.0\n---\nversion: 1\nsource: [1, 2",
        "%YAML:1.0\n---\na: " + deep + "\n",
        "%YAML:1.0\n---\na: " + std::string(5000, '{') + "\n",
        dashes,
        "%YAML:1.0\n---\n" + std::string(200, ' ') + "a: 1\n",
        "%YAML:1.0\n---\n- 1\n- 2\n",
        "%YAML:1.0\n---\nversion: 1\n",
        "<?xml version=\"1.0\"?><opencv_storage><version>1</version></opencv_storage>",
        "{\"version\": 1}",
        std::string(2 << 20, ' '),
    };
    for (const std::string& input : inputs) {
        const auto start = std::chrono::steady_clock::now();
        const auto parsed = ParseCalibration(input);
        const double seconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        EXPECT_TRUE(IsInvalidWith(parsed, "")) << input.substr(0, 40);
        EXPECT_LT(seconds, 1.0) << input.substr(0, 40);
    }
}

// The derived values come last and are checked, so a cut file is refused unless what was cut
// changes nothing (the final newline; the "." of an integral focal length written as "902.").
TEST(CalibrationFileTest, TruncatedFilesAreInvalidOrUnchanged) {
    const StereoCalibration calibration = ChessboardLikeCalibration();
    const std::string yaml = SerializeCalibration(calibration);
    int parsed_count = 0;
    for (std::size_t size = 0; size < yaml.size(); ++size) {
        const auto parsed = ParseCalibration(yaml.substr(0, size));
        if (parsed.ok()) {
            ++parsed_count;
            ExpectSame(*parsed, calibration);
        } else {
            EXPECT_TRUE(IsInvalidWith(parsed, "")) << size;
        }
    }
    EXPECT_LE(parsed_count, 2);
}

TEST(CalibrationFileTest, WrongTypesSizesAndValuesNameTheKey) {
    const std::string yaml = SerializeCalibration(ChessboardLikeCalibration());
    const std::string fx = "fx: 9.0050000000000000e+02";
    ASSERT_NE(yaml.find(fx), std::string::npos) << yaml;
    const std::string r_rows = "R: !!opencv-matrix\n   rows: 3";
    struct Case {
        std::string from, to, expected;
    };
    const std::vector<Case> cases = {
        {fx, "fx: abc", "'left.fx' must be a finite number"},
        {fx, "fx: [1, 2]", "'left.fx' must be a finite number"},
        {fx, "fx: .Nan", "'left.fx' must be a finite number"},
        {fx, "fx: -.Inf", "'left.fx' must be a finite number"},
        {fx, "fz: 1.", "missing key 'left.fx'"},
        {fx, "fx: -9.0050000000000000e+02", "left.fx must be positive and finite"},
        {"image_width: 1280", "image_width: 1280.5", "'image_width' must be an integer"},
        {"image_width: 1280", "image_width: 100000", "image_width must be in [16, 8192]"},
        {"source: chessboard", "source: magic", "'source' must be 'chessboard' or 'parameters'"},
        {"source: chessboard", "source: [1]", "'source' must be a string"},
        {r_rows, "R: !!opencv-matrix\n   rows: 100000", "'R' must be a 3x3 matrix of doubles"},
        {r_rows, "R: !!opencv-matrix\n   rows: 4", "'R' must be a 3x3 matrix of doubles"},
        {"   dt: d", "   dt: f", "'R' must be a 3x3 matrix of doubles"},
        {"data: [ ", "data: [ 1., ", "'R.data' must be a list of at most 9 numbers"},
        {"left:\n", "left: 3\nold_left:\n", "left must be a map"},
        {"rms_reprojection_px: ", "rms_reprojection_px: -", "'rms_reprojection_px' is negative"},
        {"{ index:0,", "{ index:zero,", "'pairs[0].index' must be an integer"},
        {"reason:\"left", "reason:5, r:\"left", "'skipped[0].reason' must be a string"},
        {"pairs:", "pairs: 3\nold_pairs:", "'pairs' must be a list"},
    };
    for (const Case& c : cases) {
        EXPECT_TRUE(IsInvalidWith(ParseCalibration(Replaced(yaml, c.from, c.to)), c.expected))
            << c.to;
    }
}

// `yaml` with the value after the first `key` (up to the end of its line) replaced.
std::string WithValue(std::string yaml, const std::string& key, const std::string& value) {
    const std::size_t at = yaml.find(key);
    EXPECT_NE(at, std::string::npos) << key;
    if (at == std::string::npos) return yaml;
    const std::size_t start = at + key.size();
    yaml.replace(start, yaml.find('\n', start) - start, value);
    return yaml;
}

// A hand-edited file whose parameters no longer give its rectification is caught.
TEST(CalibrationFileTest, EditedParametersThatBreakTheRectificationAreCaught) {
    const std::string yaml = SerializeCalibration(ParametersCalibration());
    EXPECT_TRUE(IsInvalidWith(ParseCalibration(WithValue(yaml, "fx: ", "910.")),
                              "'P1' does not match the rectification of the stored parameters"));
    EXPECT_TRUE(IsInvalidWith(ParseCalibration(WithValue(yaml, "cy: ", "300.")),
                              "does not match the rectification"));
    EXPECT_TRUE(IsInvalidWith(ParseCalibration(WithValue(yaml, "focal_px: ", "1000.")),
                              "'focal_px' does not match"));
    EXPECT_TRUE(IsInvalidWith(ParseCalibration(WithValue(yaml, "baseline_m: ", "0.5")),
                              "'baseline_m' does not match"));
}

// Mutations of valid files: every outcome must be OK or InvalidArgument, never a crash.
TEST(CalibrationFileTest, FuzzedFilesNeverCrash) {
    const std::vector<std::string> seeds = {SerializeCalibration(ParametersCalibration()),
                                            SerializeCalibration(ChessboardLikeCalibration())};
    const std::string specials = "[]{}:-,#'\"!&* \n\t.e+0123456789";
    std::mt19937 rng(2024);
    int ok = 0;
    for (int iteration = 0; iteration < 3000; ++iteration) {
        std::string bytes = seeds[rng() % seeds.size()];
        switch (rng() % 5) {
            case 0:  // flip a few bytes
                for (unsigned k = 0, n = 1 + rng() % 4; k < n; ++k) {
                    bytes[rng() % bytes.size()] = static_cast<char>(rng());
                }
                break;
            case 1:  // truncate
                bytes.resize(rng() % bytes.size());
                break;
            case 2:  // YAML syntax characters in random places
                for (unsigned k = 0, n = 1 + rng() % 3; k < n; ++k) {
                    bytes.insert(rng() % bytes.size(), 1, specials[rng() % specials.size()]);
                }
                break;
            case 3: {  // delete or duplicate a line
                const std::size_t begin = bytes.rfind('\n', rng() % bytes.size());
                const std::size_t line_start = begin == std::string::npos ? 0 : begin + 1;
                const std::size_t end = bytes.find('\n', line_start);
                const std::string line =
                    bytes.substr(line_start, end == std::string::npos ? std::string::npos
                                                                      : end - line_start + 1);
                if (rng() % 2 == 0) {
                    bytes.erase(line_start, line.size());
                } else {
                    bytes.insert(line_start, line);
                }
                break;
            }
            default:  // change one digit (matrix sizes, values, version)
                for (std::size_t i = rng() % bytes.size(); i < bytes.size(); ++i) {
                    if (bytes[i] >= '0' && bytes[i] <= '9') {
                        bytes[i] = static_cast<char>('0' + rng() % 10);
                        break;
                    }
                }
                break;
        }
        const auto parsed = ParseCalibration(bytes);
        if (parsed.ok()) {
            ++ok;
        } else {
            ASSERT_EQ(parsed.status().code(), absl::StatusCode::kInvalidArgument)
                << parsed.status();
        }
    }
    EXPECT_GT(ok, 0);
}

}  // namespace
}  // namespace soilvol::stereo
