// Degrees and radians: the plant computes in radians and reports in degrees.
#pragma once
#include <numbers>

namespace plant {
inline constexpr double kRadToDeg = 180.0 / std::numbers::pi;
inline constexpr double kDegToRad = std::numbers::pi / 180.0;
}  // namespace plant
