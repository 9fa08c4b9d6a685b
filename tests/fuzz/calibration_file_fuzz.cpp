// libFuzzer: the stored calibration reader (OpenCV YAML behind our own structure checks). A
// calibration it accepts must serialize and read back to the same rig.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "core/stereo/calibration_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string_view yaml(reinterpret_cast<const char*>(data), size);
    const auto calibration = soilvol::stereo::ParseCalibration(yaml);
    if (!calibration.ok()) return 0;
    const auto again =
        soilvol::stereo::ParseCalibration(soilvol::stereo::SerializeCalibration(*calibration));
    if (!again.ok()) std::abort();
    if (std::abs(again->baseline_m - calibration->baseline_m) >
        1e-9 * std::max(1.0, std::abs(calibration->baseline_m))) {
        std::abort();
    }
    return 0;
}
