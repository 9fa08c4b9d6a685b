#include "core/io/ply_header.hpp"

#include <algorithm>
#include <initializer_list>
#include <utility>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/common/status_macros.hpp"
#include "core/io/text_scanner.hpp"

namespace soilvol::io::detail {
namespace {

using Tokens = std::vector<std::string_view>;

absl::Status HeaderError(absl::string_view what) {
    return absl::InvalidArgumentError(absl::StrCat("PLY header: ", what));
}

std::optional<ScalarType> PlyScalarType(std::string_view name) {
    static constexpr std::pair<std::string_view, ScalarType> kNames[] = {
        {"char", ScalarType::kInt8},      {"int8", ScalarType::kInt8},
        {"uchar", ScalarType::kUint8},    {"uint8", ScalarType::kUint8},
        {"short", ScalarType::kInt16},    {"int16", ScalarType::kInt16},
        {"ushort", ScalarType::kUint16},  {"uint16", ScalarType::kUint16},
        {"int", ScalarType::kInt32},      {"int32", ScalarType::kInt32},
        {"uint", ScalarType::kUint32},    {"uint32", ScalarType::kUint32},
        {"float", ScalarType::kFloat32},  {"float32", ScalarType::kFloat32},
        {"double", ScalarType::kFloat64}, {"float64", ScalarType::kFloat64},
    };
    for (const auto& [text, type] : kNames) {
        if (text == name) return type;
    }
    return std::nullopt;
}

absl::StatusOr<ScalarType> ParseType(std::string_view name) {
    const std::optional<ScalarType> type = PlyScalarType(name);
    if (!type) return HeaderError(absl::StrCat("unknown property type '", Printable(name), "'"));
    return *type;
}

// The index of the one item with one of `names`: nullopt for none, `repeated` for several.
template <typename Item>
absl::StatusOr<std::optional<std::size_t>> FindOne(const std::vector<Item>& items,
                                                   std::initializer_list<std::string_view> names,
                                                   absl::string_view repeated) {
    std::optional<std::size_t> found;
    for (std::size_t i = 0; i < items.size(); ++i) {
        if (std::find(names.begin(), names.end(), items[i].name) == names.end()) continue;
        if (found) return HeaderError(repeated);
        found = i;
    }
    return found;
}

// Collects header lines in order, then checks the vertex element (and a mesh's face element).
class PlyHeaderParser {
  public:
    absl::Status ParseLine(const Tokens& tokens) {
        const std::string_view keyword = tokens[0];
        if (keyword == "comment" || keyword == "obj_info") return absl::OkStatus();
        if (keyword == "format") return ParseFormat(tokens);
        if (keyword == "element") return ParseElement(tokens);
        if (keyword == "property") return ParseProperty(tokens);
        return HeaderError(absl::StrCat("unknown keyword '", Printable(keyword), "'"));
    }

    absl::StatusOr<PlyHeader> Finish(std::size_t body_offset, PlyContent content) && {
        if (!format_seen_) return HeaderError("missing format line");
        header_.body_offset = body_offset;
        SOILVOL_RETURN_IF_ERROR(FindVertexXyz());
        if (content == PlyContent::kMesh) {
            SOILVOL_RETURN_IF_ERROR(FindFaceIndices());
            return std::move(header_);
        }
        if (header_.elements[header_.vertex_element].count == 0) {
            return absl::InvalidArgumentError("cloud has no points (PLY vertex count is 0)");
        }
        if (header_.elements[header_.vertex_element].count > kMaxPoints) {
            return HeaderError(absl::StrCat("vertex count ",
                                            header_.elements[header_.vertex_element].count,
                                            " is more than the ", kMaxPoints, " a scan may hold"));
        }
        return std::move(header_);
    }

  private:
    absl::Status ParseFormat(const Tokens& tokens) {
        if (format_seen_) return HeaderError("more than one format line");
        if (tokens.size() != 3) return HeaderError("format line needs an encoding and a version");
        if (tokens[1] == "ascii") {
            header_.format = PlyFormat::kAscii;
        } else if (tokens[1] == "binary_little_endian") {
            header_.format = PlyFormat::kBinaryLittleEndian;
        } else if (tokens[1] == "binary_big_endian") {
            header_.format = PlyFormat::kBinaryBigEndian;
        } else {
            return HeaderError(absl::StrCat("unknown format '", Printable(tokens[1]), "'"));
        }
        if (tokens[2] != "1.0" && tokens[2] != "1") {
            return HeaderError(absl::StrCat("unsupported version '", Printable(tokens[2]), "'"));
        }
        format_seen_ = true;
        return absl::OkStatus();
    }

    absl::Status ParseElement(const Tokens& tokens) {
        PlyElement element;
        if (tokens.size() != 3 || !ParseUint64(tokens[2], &element.count)) {
            return HeaderError("element line needs a name and a non-negative count");
        }
        element.name = std::string(tokens[1]);
        header_.elements.push_back(std::move(element));
        return absl::OkStatus();
    }

    absl::Status ParseProperty(const Tokens& tokens) {
        if (header_.elements.empty()) return HeaderError("property before any element");
        PlyProperty property;
        if (tokens.size() == 5 && tokens[1] == "list") {
            SOILVOL_ASSIGN_OR_RETURN(const ScalarType count_type, ParseType(tokens[2]));
            if (IsFloating(count_type)) return HeaderError("list count type must be an integer");
            property.list_count_type = count_type;
            SOILVOL_ASSIGN_OR_RETURN(property.type, ParseType(tokens[3]));
        } else if (tokens.size() == 3) {
            SOILVOL_ASSIGN_OR_RETURN(property.type, ParseType(tokens[1]));
        } else {
            return HeaderError("malformed property line");
        }
        property.name = std::string(tokens.back());
        header_.elements.back().properties.push_back(std::move(property));
        return absl::OkStatus();
    }

    absl::Status FindVertexXyz() {
        SOILVOL_ASSIGN_OR_RETURN(
            const std::optional<std::size_t> vertex,
            FindOne(header_.elements, {"vertex"}, "more than one vertex element"));
        if (!vertex) return HeaderError("no vertex element");
        header_.vertex_element = *vertex;
        static constexpr const char* kAxes[] = {"x", "y", "z"};
        for (std::size_t axis = 0; axis < 3; ++axis) {
            SOILVOL_ASSIGN_OR_RETURN(header_.xyz_property[axis], FindCoordinate(kAxes[axis]));
        }
        return absl::OkStatus();
    }

    absl::StatusOr<std::size_t> FindCoordinate(const char* axis) const {
        const auto& properties = header_.elements[header_.vertex_element].properties;
        SOILVOL_ASSIGN_OR_RETURN(
            const std::optional<std::size_t> index,
            FindOne(properties, {axis}, absl::StrCat("vertex property '", axis, "' repeats")));
        if (!index) return HeaderError(absl::StrCat("vertex element has no '", axis, "' property"));
        const PlyProperty& property = properties[*index];
        if (property.list_count_type) {
            return HeaderError(absl::StrCat("vertex property '", axis, "' is a list"));
        }
        if (!IsFloating(property.type)) {
            return HeaderError(absl::StrCat("vertex property '", axis, "' has type ",
                                            ScalarTypeName(property.type),
                                            "; expected float or double"));
        }
        return *index;
    }

    // A mesh's one `face` element and its integer list of vertex indices.
    absl::Status FindFaceIndices() {
        SOILVOL_ASSIGN_OR_RETURN(const std::optional<std::size_t> face,
                                 FindOne(header_.elements, {"face"}, "more than one face element"));
        if (!face) return HeaderError("no face element (a mesh needs one)");
        header_.face_element = *face;
        const auto& properties = header_.elements[*face].properties;
        SOILVOL_ASSIGN_OR_RETURN(const std::optional<std::size_t> index,
                                 FindOne(properties, {"vertex_indices", "vertex_index"},
                                         "face element has more than one vertex index list"));
        if (!index) return HeaderError("face element has no 'vertex_indices' list");
        const PlyProperty& property = properties[*index];
        if (!property.list_count_type) return HeaderError("face 'vertex_indices' is not a list");
        if (IsFloating(property.type)) {
            return HeaderError(absl::StrCat("face 'vertex_indices' has type ",
                                            ScalarTypeName(property.type),
                                            "; expected an integer type"));
        }
        header_.face_indices_property = *index;
        return absl::OkStatus();
    }

    PlyHeader header_;
    bool format_seen_ = false;
};

}  // namespace

absl::StatusOr<PlyHeader> ParsePlyHeader(std::string_view bytes, PlyContent content) {
    LineReader lines(bytes, kMaxHeaderBytes);
    std::string_view line;
    if (!lines.Next(&line) || line != "ply") return HeaderError("missing 'ply' magic line");
    PlyHeaderParser parser;
    while (lines.Next(&line)) {
        const Tokens tokens = SplitTokens(line);
        if (tokens.empty()) continue;
        if (tokens[0] == "end_header") {
            if (tokens.size() != 1) return HeaderError("text after end_header");
            if (!lines.last_line_terminated()) {
                return HeaderError("end_header must be followed by a newline");
            }
            return std::move(parser).Finish(lines.offset(), content);
        }
        SOILVOL_RETURN_IF_ERROR(parser.ParseLine(tokens));
    }
    if (lines.hit_limit()) {
        return HeaderError(
            absl::StrCat("no end_header within the first ", kMaxHeaderBytes, " bytes"));
    }
    return HeaderError("input ends before end_header");
}

}  // namespace soilvol::io::detail
