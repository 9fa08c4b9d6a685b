#include "core/io/pcd_header.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <utility>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/common/status_macros.hpp"
#include "core/io/text_scanner.hpp"

namespace soilvol::io::detail {
namespace {

using Tokens = std::vector<std::string_view>;

absl::Status HeaderError(absl::string_view what) {
    return absl::InvalidArgumentError(absl::StrCat("PCD header: ", what));
}

constexpr std::string_view kKeywords[] = {"VERSION", "FIELDS", "SIZE",   "TYPE", "COUNT",
                                          "WIDTH",   "HEIGHT", "POINTS", "DATA", "VIEWPOINT"};

// Seven written digits give a norm within 1e-6 of 1; more than 1e-3 off is not a rotation.
constexpr double kUnitQuaternionTolerance = 1e-3;

absl::Status CheckField(const PcdField& field) {
    const std::string where = absl::StrCat(" of field '", Printable(field.name), "'");
    if (field.size != 1 && field.size != 2 && field.size != 4 && field.size != 8) {
        return HeaderError(absl::StrCat("SIZE ", field.size, where, " is not 1, 2, 4 or 8"));
    }
    if (field.type != 'I' && field.type != 'U' && field.type != 'F') {
        return HeaderError(absl::StrCat("TYPE", where, " is not I, U or F"));
    }
    if (field.type == 'F' && field.size < 4) {
        return HeaderError(absl::StrCat("TYPE F", where, " needs SIZE 4 or 8"));
    }
    if (field.count == 0) return HeaderError(absl::StrCat("COUNT", where, " is 0"));
    return absl::OkStatus();
}

// Collects the keyword lines up to DATA (PCL's reader ignores unknown keywords, so do we).
class PcdHeaderParser {
  public:
    absl::Status ParseLine(const Tokens& tokens) {
        const std::string_view key = tokens[0];
        if (std::find(std::begin(kKeywords), std::end(kKeywords), key) == std::end(kKeywords)) {
            return absl::OkStatus();
        }
        if (std::find(seen_.begin(), seen_.end(), key) != seen_.end()) {
            return HeaderError(absl::StrCat("duplicate ", std::string(key), " line"));
        }
        seen_.push_back(key);
        const Tokens values(tokens.begin() + 1, tokens.end());
        if (key == "VERSION") return ParseVersion(values);
        if (key == "FIELDS") return ParseFields(values);
        if (key == "SIZE") return ParseNumbers("SIZE", values, &sizes_);
        if (key == "TYPE") return ParseTypes(values);
        if (key == "COUNT") return ParseNumbers("COUNT", values, &counts_);
        if (key == "WIDTH") return ParseSingle("WIDTH", values, &width_);
        if (key == "HEIGHT") return ParseSingle("HEIGHT", values, &height_);
        if (key == "POINTS") return ParseSingle("POINTS", values, &points_);
        if (key == "DATA") return ParseData(values);
        return ParseViewpoint(values);
    }

    absl::StatusOr<PcdHeader> Finish(std::size_t body_offset) && {
        header_.body_offset = body_offset;
        SOILVOL_RETURN_IF_ERROR(BuildFields());
        SOILVOL_RETURN_IF_ERROR(FindXyz());
        SOILVOL_RETURN_IF_ERROR(ResolvePoints());
        return std::move(header_);
    }

  private:
    absl::Status ParseVersion(const Tokens& values) {
        if (values.size() == 1 && (values[0] == ".7" || values[0] == "0.7")) {
            return absl::OkStatus();
        }
        return HeaderError("unsupported VERSION (expected 0.7)");
    }

    absl::Status ParseFields(const Tokens& values) {
        if (values.empty()) return HeaderError("FIELDS line is empty");
        for (const std::string_view name : values) header_.fields.push_back({std::string(name)});
        return absl::OkStatus();
    }

    absl::Status ParseNumbers(const char* key, const Tokens& values,
                              std::vector<std::uint64_t>* numbers) {
        for (const std::string_view value : values) {
            std::uint64_t number = 0;
            if (!ParseUint64(value, &number)) {
                return HeaderError(absl::StrCat(key, " value '", Printable(value),
                                                "' is not a non-negative integer"));
            }
            numbers->push_back(number);
        }
        return absl::OkStatus();
    }

    absl::Status ParseTypes(const Tokens& values) {
        for (const std::string_view value : values) {
            if (value.size() != 1) {
                return HeaderError(
                    absl::StrCat("TYPE value '", Printable(value), "' is not I, U or F"));
            }
            types_.push_back(value[0]);
        }
        return absl::OkStatus();
    }

    absl::Status ParseSingle(const char* key, const Tokens& values,
                             std::optional<std::uint64_t>* number) {
        std::uint64_t value = 0;
        if (values.size() != 1 || !ParseUint64(values[0], &value)) {
            return HeaderError(absl::StrCat(key, " needs one non-negative integer"));
        }
        *number = value;
        return absl::OkStatus();
    }

    // VIEWPOINT tx ty tz qw qx qy qz: the sensor's position and orientation (a unit quaternion,
    // normalised here) in the cloud's frame, as PCL's sensor_origin_ / sensor_orientation_.
    absl::Status ParseViewpoint(const Tokens& values) {
        std::array<double, 7> v{};
        if (values.size() != v.size()) {
            return HeaderError(absl::StrCat("VIEWPOINT needs 7 numbers, got ", values.size()));
        }
        for (std::size_t i = 0; i < v.size(); ++i) {
            if (!ParseFiniteDouble(values[i], &v[i])) {
                return HeaderError(
                    absl::StrCat("VIEWPOINT value '", Printable(values[i]), "' is not a number"));
            }
        }
        Eigen::Quaterniond q(v[3], v[4], v[5], v[6]);
        const double norm = q.norm();
        if (!(std::abs(norm - 1.0) <= kUnitQuaternionTolerance)) {
            return HeaderError(absl::StrCat(
                "VIEWPOINT orientation qw qx qy qz is not a unit quaternion (norm ", norm, ")"));
        }
        q.normalize();
        header_.viewpoint = Pose::Identity();
        header_.viewpoint.linear() = q.toRotationMatrix();
        header_.viewpoint.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
        return absl::OkStatus();
    }

    absl::Status ParseData(const Tokens& values) {
        if (values.size() == 1 && values[0] == "ascii") {
            header_.data = PcdData::kAscii;
        } else if (values.size() == 1 && values[0] == "binary") {
            header_.data = PcdData::kBinary;
        } else if (values.size() == 1 && values[0] == "binary_compressed") {
            header_.data = PcdData::kBinaryCompressed;
        } else {
            return HeaderError("DATA must be ascii, binary or binary_compressed");
        }
        return absl::OkStatus();
    }

    absl::Status BuildFields() {
        auto& fields = header_.fields;
        if (fields.empty()) return HeaderError("missing FIELDS line");
        if (counts_.empty()) counts_.assign(fields.size(), 1);
        if (sizes_.size() != fields.size() || types_.size() != fields.size() ||
            counts_.size() != fields.size()) {
            return HeaderError(absl::StrCat("FIELDS has ", fields.size(), " entries but SIZE has ",
                                            sizes_.size(), ", TYPE ", types_.size(), " and COUNT ",
                                            counts_.size()));
        }
        for (std::size_t i = 0; i < fields.size(); ++i) {
            fields[i].size = sizes_[i];
            fields[i].type = types_[i];
            fields[i].count = counts_[i];
            SOILVOL_RETURN_IF_ERROR(CheckField(fields[i]));
            std::uint64_t bytes = 0;
            if (!CheckedMul(fields[i].size, fields[i].count, &bytes) ||
                !CheckedAdd(header_.point_size, bytes, &header_.point_size)) {
                return HeaderError("point size overflows");
            }
        }
        return absl::OkStatus();
    }

    absl::Status FindXyz() {
        static constexpr const char* kAxes[] = {"x", "y", "z"};
        const auto& fields = header_.fields;
        for (std::size_t axis = 0; axis < 3; ++axis) {
            const auto is_axis = [&](const PcdField& f) { return f.name == kAxes[axis]; };
            const auto it = std::find_if(fields.begin(), fields.end(), is_axis);
            const std::string name = absl::StrCat("field '", kAxes[axis], "'");
            if (it == fields.end()) return HeaderError(absl::StrCat("missing ", name));
            if (std::find_if(it + 1, fields.end(), is_axis) != fields.end()) {
                return HeaderError(absl::StrCat(name, " repeats"));
            }
            if (it->type != 'F' || it->count != 1) {
                return HeaderError(absl::StrCat(name, " must be TYPE F with COUNT 1"));
            }
            header_.xyz_field[axis] = static_cast<std::size_t>(it - fields.begin());
        }
        return absl::OkStatus();
    }

    // Files without WIDTH and HEIGHT are one row of POINTS points, as PCL reads them.
    absl::Status ResolvePoints() {
        if (!width_ && !height_) {
            if (!points_) return HeaderError("missing WIDTH, HEIGHT and POINTS");
            width_ = points_;
        }
        if (!width_) return HeaderError("HEIGHT without WIDTH");
        header_.width = *width_;
        header_.height = height_.value_or(1);
        if (!CheckedMul(header_.width, header_.height, &header_.points)) {
            return HeaderError("WIDTH * HEIGHT overflows");
        }
        if (points_ && *points_ != header_.points) {
            return HeaderError(absl::StrCat("POINTS ", *points_, " != WIDTH * HEIGHT = ",
                                            header_.width, " * ", header_.height));
        }
        if (header_.points == 0) {
            return absl::InvalidArgumentError("cloud has no points (PCD POINTS is 0)");
        }
        if (header_.points > kMaxPoints) {
            return HeaderError(absl::StrCat("POINTS ", header_.points, " is more than the ",
                                            kMaxPoints, " a scan may hold"));
        }
        return absl::OkStatus();
    }

    PcdHeader header_;
    std::vector<std::string_view> seen_;
    std::vector<std::uint64_t> sizes_;
    std::vector<std::uint64_t> counts_;
    std::vector<char> types_;
    std::optional<std::uint64_t> width_;
    std::optional<std::uint64_t> height_;
    std::optional<std::uint64_t> points_;
};

}  // namespace

absl::StatusOr<PcdHeader> ParsePcdHeader(std::string_view bytes) {
    LineReader lines(bytes, kMaxHeaderBytes);
    PcdHeaderParser parser;
    std::string_view line;
    while (lines.Next(&line)) {
        const Tokens tokens = SplitTokens(line);
        if (tokens.empty() || tokens[0][0] == '#') continue;
        SOILVOL_RETURN_IF_ERROR(parser.ParseLine(tokens));
        if (tokens[0] == "DATA") return std::move(parser).Finish(lines.offset());
    }
    if (lines.hit_limit()) {
        return HeaderError(
            absl::StrCat("no DATA line within the first ", kMaxHeaderBytes, " bytes"));
    }
    return HeaderError("input ends before the DATA line");
}

}  // namespace soilvol::io::detail
