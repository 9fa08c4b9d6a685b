#pragma once

#include <optional>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "core/common/image.hpp"

namespace soilvol::volume {

/// The heights of a packed heightmap (PackedHeights: little-endian float32, row-major from the
/// grid's min corner). InvalidArgument unless `bytes` holds exactly cols x rows values and the
/// grid is at most 4096 cells a side.
absl::StatusOr<std::vector<float>> UnpackHeights(std::string_view bytes, int cols, int rows);

/// A colour map of soil heights for people: viridis over the observed heights (at least 5 cm
/// of range, so that noise on a flat load stays one colour), +y up, each cell a square of
/// `cell_px` pixels (1..64), unobserved cells (NaN) light grey, and the load centre - given
/// in cells from the min corner - marked with a white ring and a red cross.
RgbImage RenderHeightmap(const std::vector<float>& heights, int cols, int rows, int cell_px,
                         std::optional<std::pair<double, double>> centre_cells);

}  // namespace soilvol::volume
