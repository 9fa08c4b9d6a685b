// libFuzzer: a stored calibration as the server reads it back: the store record's framing
// (server::DecodeStoredRecord), the Calibration message in it, and the rig rebuilt from its
// parameters (server::ToStereoCalibration, which rectifies them with OpenCV). A rig rebuilt
// from any bytes has a positive finite baseline and focal length.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "proto/convert/proto_convert.hpp"
#include "server/handlers/stored_record.hpp"
#include "soilvol/v1/soilvol.pb.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string_view payload(reinterpret_cast<const char*>(data), size);
    soilvol::v1::Calibration info;
    std::string_view body;
    if (!soilvol::server::DecodeStoredRecord(payload, &info, &body).ok()) return 0;
    if (body.size() > payload.size()) std::abort();
    const auto calibration = soilvol::server::ToStereoCalibration(info);
    if (!calibration.ok()) return 0;
    if (!(std::isfinite(calibration->baseline_m) && calibration->baseline_m > 0.0 &&
          std::isfinite(calibration->focal_px) && calibration->focal_px > 0.0)) {
        std::abort();
    }
    return 0;
}
