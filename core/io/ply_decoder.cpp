#include "core/io/ply_decoder.hpp"

#include <array>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/common/status_macros.hpp"
#include "core/io/point_sink.hpp"
#include "core/io/scalar_type.hpp"

namespace soilvol::io::detail {
namespace {

absl::Status BodyError(absl::string_view what) {
    return absl::InvalidArgumentError(absl::StrCat("PLY body: ", what));
}

}  // namespace

PlyEntryLayout LayoutOf(const PlyElement& element) {
    PlyEntryLayout layout;
    for (const PlyProperty& property : element.properties) {
        if (property.list_count_type) {
            layout.min_stride += ScalarSize(*property.list_count_type);
            layout.fixed = false;
        } else {
            layout.min_stride += ScalarSize(property.type);
        }
    }
    return layout;
}

absl::Status CheckBinaryFits(const PlyElement& element, const PlyEntryLayout& layout,
                             std::size_t available) {
    std::uint64_t needed = 0;
    if (!CheckedMul(element.count, layout.min_stride, &needed)) {
        return BodyError(absl::StrCat(element.name, " count ", element.count, " times ",
                                      layout.min_stride, " bytes overflows"));
    }
    if (needed > available) {
        return BodyError(absl::StrCat(element.name, " count ", element.count, " needs ",
                                      layout.fixed ? "" : "at least ", needed, " bytes but only ",
                                      available, " follow"));
    }
    return absl::OkStatus();
}

absl::StatusOr<std::size_t> BinaryEntrySize(const PlyElement& element, std::string_view data,
                                            bool swap, std::vector<std::size_t>* offsets) {
    const auto truncated = [&element] {
        return BodyError(absl::StrCat("element '", element.name, "' is truncated"));
    };
    std::size_t pos = 0;
    for (std::size_t k = 0; k < element.properties.size(); ++k) {
        const PlyProperty& property = element.properties[k];
        if (offsets != nullptr) (*offsets)[k] = pos;
        if (!property.list_count_type) {
            if (ScalarSize(property.type) > data.size() - pos) return truncated();
            pos += ScalarSize(property.type);
            continue;
        }
        const std::size_t count_size = ScalarSize(*property.list_count_type);
        if (count_size > data.size() - pos) return truncated();
        const std::optional<std::uint64_t> items =
            LoadCount(data.data() + pos, *property.list_count_type, swap);
        if (!items) {
            return BodyError(absl::StrCat("negative list count in element '", element.name, "'"));
        }
        pos += count_size;
        // Fewer than 2^32 items of at most 8 bytes: no overflow.
        const std::uint64_t list_bytes = *items * ScalarSize(property.type);
        if (list_bytes > data.size() - pos) return truncated();
        pos += list_bytes;
    }
    return pos;
}

absl::StatusOr<std::size_t> SkipBinaryElement(const PlyElement& element, std::string_view data,
                                              bool swap) {
    const PlyEntryLayout layout = LayoutOf(element);
    SOILVOL_RETURN_IF_ERROR(CheckBinaryFits(element, layout, data.size()));
    if (layout.fixed) return element.count * layout.min_stride;
    std::size_t pos = 0;
    for (std::uint64_t i = 0; i < element.count; ++i) {
        SOILVOL_ASSIGN_OR_RETURN(const std::size_t size,
                                 BinaryEntrySize(element, data.substr(pos), swap, nullptr));
        pos += size;
    }
    return pos;
}

namespace {

absl::StatusOr<DecodedCloud> DecodeVertices(const PlyHeader& header, std::string_view data,
                                            bool swap) {
    const PlyElement& vertex = header.elements[header.vertex_element];
    const PlyEntryLayout layout = LayoutOf(vertex);
    SOILVOL_RETURN_IF_ERROR(CheckBinaryFits(vertex, layout, data.size()));
    std::array<ScalarType, 3> types{};
    for (std::size_t axis = 0; axis < 3; ++axis) {
        types[axis] = vertex.properties[header.xyz_property[axis]].type;
    }
    const auto& [ix, iy, iz] = header.xyz_property;
    PointSink sink(CloudFormat::kPly, vertex.count);
    std::vector<std::size_t> offsets(vertex.properties.size());
    std::size_t pos = 0;
    for (std::uint64_t i = 0; i < vertex.count; ++i) {
        const char* entry = data.data() + pos;
        if (layout.fixed && i > 0) {
            pos += layout.min_stride;  // offsets are the same for every entry
        } else {
            SOILVOL_ASSIGN_OR_RETURN(const std::size_t size,
                                     BinaryEntrySize(vertex, data.substr(pos), swap, &offsets));
            pos += size;
        }
        sink.Add(LoadCoordinate(entry + offsets[ix], types[0], swap),
                 LoadCoordinate(entry + offsets[iy], types[1], swap),
                 LoadCoordinate(entry + offsets[iz], types[2], swap));
    }
    return std::move(sink).Finish();
}

}  // namespace

absl::StatusOr<DecodedCloud> DecodePly(std::string_view bytes) {
    SOILVOL_ASSIGN_OR_RETURN(const PlyHeader header, ParsePlyHeader(bytes));
    const std::string_view body = bytes.substr(header.body_offset);
    if (header.format == PlyFormat::kAscii) return DecodePlyAsciiBody(header, body);
    return DecodePlyBinaryBody(header, body);
}

absl::StatusOr<DecodedCloud> DecodePlyBinaryBody(const PlyHeader& header, std::string_view body) {
    const bool file_little_endian = header.format == PlyFormat::kBinaryLittleEndian;
    const bool swap = file_little_endian != kHostIsLittleEndian;
    // Elements before the vertex element are skipped; elements after it are ignored.
    for (std::size_t e = 0; e < header.vertex_element; ++e) {
        SOILVOL_ASSIGN_OR_RETURN(const std::size_t size,
                                 SkipBinaryElement(header.elements[e], body, swap));
        body.remove_prefix(size);
    }
    return DecodeVertices(header, body, swap);
}

}  // namespace soilvol::io::detail
