#pragma once

// Private to core/io: point bodies shared by the PLY, PCD and raw encoders.

#include <string>

#include "core/common/types.hpp"

namespace soilvol::io::detail {

/// Appends one "x y z\n" line per point, each float in its shortest exact decimal form.
void AppendAsciiXyz(const Cloud& points, std::string* out);

/// Appends x, y, z of each point as float32, big-endian when `big_endian`.
void AppendBinaryXyz(const Cloud& points, bool big_endian, std::string* out);

}  // namespace soilvol::io::detail
