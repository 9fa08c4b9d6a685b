#pragma once

namespace soilvol {

inline constexpr double kPi = 3.14159265358979323846;

/// Degrees to radians and back.
inline constexpr double Radians(double deg) { return deg * kPi / 180.0; }
inline constexpr double Degrees(double rad) { return rad * 180.0 / kPi; }

}  // namespace soilvol
