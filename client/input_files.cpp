#include "client/input_files.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>

#include "absl/strings/ascii.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "client/connection.hpp"

namespace soilvol::client {
namespace {

namespace fs = std::filesystem;

bool IsImageExtension(std::string extension) {
    extension = absl::AsciiStrToLower(extension);
    return extension == ".png" || extension == ".jpg" || extension == ".jpeg";
}

}  // namespace

absl::StatusOr<std::string> ReadFile(const std::string& path) {
    std::error_code error;
    if (fs::is_directory(path, error)) {
        return absl::InvalidArgumentError(absl::StrCat("cannot read '", path, "': is a directory"));
    }
    std::ifstream file(path, std::ios::binary);
    if (!file) {
        return absl::InvalidArgumentError(
            absl::StrCat("cannot read '", path, "': ", std::strerror(errno)));
    }
    std::string content;
    std::vector<char> buffer(1 << 20);
    while (file.read(buffer.data(), static_cast<std::streamsize>(buffer.size())) ||
           file.gcount() > 0) {
        content.append(buffer.data(), static_cast<size_t>(file.gcount()));
    }
    if (file.bad()) {
        return absl::InvalidArgumentError(absl::StrCat("cannot read '", path, "': read error"));
    }
    return content;
}

absl::StatusOr<std::vector<ImagePairFiles>> FindChessboardPairs(
    const std::string& dir, std::vector<std::string>* unpaired) {
    std::map<std::string, std::string> lefts;
    std::map<std::string, std::string> rights;
    std::error_code error;
    fs::directory_iterator it(dir, error);
    if (error) {
        return absl::InvalidArgumentError(
            absl::StrCat("cannot list '", dir, "': ", error.message()));
    }
    for (const fs::directory_entry& entry : it) {
        if (!entry.is_regular_file(error) || !IsImageExtension(entry.path().extension())) continue;
        const std::string stem = entry.path().stem().string();
        absl::string_view suffix = stem;
        if (absl::ConsumePrefix(&suffix, "left")) {
            lefts[std::string(suffix)] = entry.path().string();
        } else if (absl::ConsumePrefix(&suffix, "right")) {
            rights[std::string(suffix)] = entry.path().string();
        }
    }
    std::vector<ImagePairFiles> pairs;
    for (const auto& [suffix, left] : lefts) {
        const auto right = rights.find(suffix);
        if (right == rights.end()) {
            if (unpaired != nullptr) unpaired->push_back(left);
            continue;
        }
        pairs.push_back({left, right->second});
        rights.erase(right);
    }
    if (unpaired != nullptr) {
        for (const auto& [suffix, right] : rights) unpaired->push_back(right);
    }
    if (pairs.empty()) {
        return absl::InvalidArgumentError(absl::StrCat(
            "no left*/right* image pairs (png, jpg) with matching suffixes in '", dir, "'"));
    }
    return pairs;
}

absl::StatusOr<std::vector<std::vector<double>>> ParseTuples(const std::string& text, int dims,
                                                             int count, const std::string& flag) {
    const std::string expected = absl::StrCat(flag, " needs ", count, " points of ", dims,
                                              " comma-separated numbers, ';' ", "between points");
    std::vector<std::vector<double>> tuples;
    for (absl::string_view part : absl::StrSplit(text, ';', absl::SkipWhitespace())) {
        std::vector<double> tuple;
        for (absl::string_view field : absl::StrSplit(part, ',')) {
            double value = 0.0;
            if (!absl::SimpleAtod(absl::StripAsciiWhitespace(field), &value) ||
                !std::isfinite(value)) {
                return absl::InvalidArgumentError(
                    absl::StrCat(expected, "; '", field, "' is not a number"));
            }
            tuple.push_back(value);
        }
        if (static_cast<int>(tuple.size()) != dims) {
            return absl::InvalidArgumentError(absl::StrCat(expected, "; got '", part, "'"));
        }
        tuples.push_back(std::move(tuple));
    }
    if (static_cast<int>(tuples.size()) != count) {
        return absl::InvalidArgumentError(absl::StrCat(expected, "; got ", tuples.size()));
    }
    return tuples;
}

absl::StatusOr<PoseValues> ParsePose(const std::string& text, const std::string& flag) {
    const std::vector<std::string> parts = absl::StrSplit(text, ';', absl::SkipWhitespace());
    if (parts.empty() || parts.size() > 2) {
        return absl::InvalidArgumentError(
            absl::StrCat(flag,
                         " needs \"x,y,z;qw,qx,qy,qz\" (position [m]; unit quaternion, w first) or "
                         "\"x,y,z\"; got '",
                         text, "'"));
    }
    PoseValues pose;
    auto position = ParseTuples(parts[0], 3, 1, absl::StrCat(flag, " (position)"));
    if (!position.ok()) return position.status();
    std::copy_n((*position)[0].begin(), 3, pose.position_m.begin());
    if (parts.size() == 2) {
        auto quaternion = ParseTuples(parts[1], 4, 1, absl::StrCat(flag, " (quaternion)"));
        if (!quaternion.ok()) return quaternion.status();
        const std::vector<double>& q = (*quaternion)[0];
        const double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
        if (std::abs(norm - 1.0) > 1e-3) {
            return absl::InvalidArgumentError(
                absl::StrCat(flag, ": the quaternion (w first) must have norm 1, got ", norm));
        }
        std::copy_n(q.begin(), 4, pose.quaternion.begin());
    }
    return pose;
}

int ReportUsageError(const absl::Status& status) {
    std::cerr << "error: " << status.message() << "\n";
    return kExitUsage;
}

}  // namespace soilvol::client
