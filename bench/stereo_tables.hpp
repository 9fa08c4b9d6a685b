#pragma once

#include <ostream>
#include <string>

namespace soilvol::bench {

/// Rendered stereo pairs of the paper bucket and the excavator bucket (640x480, 10 cm baseline,
/// calibrated from rendered chessboards, registered from pixel corners) at several fills.
std::string StereoFillTable(int seeds, std::ostream& kv);
/// Time per stage from two encoded images to a volume at 640x480 and 1280x720.
std::string StereoSpeedTable(int repetitions, std::ostream& kv);

}  // namespace soilvol::bench
