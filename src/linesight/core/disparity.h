// Disparity encoding shared by every module (DESIGN.md): float pixels of the left image,
// disparity = x_left - x_right >= 0, +inf marks "no estimate".
#pragma once

#include <cmath>
#include <limits>

namespace linesight {

inline constexpr float kInvalidDisparity = std::numeric_limits<float>::infinity();

inline bool IsValidDisparity(float d) { return std::isfinite(d); }

// KITTI 16-bit PNG: value = round(d * 256), 0 = invalid.
inline constexpr float kKittiDisparityScale = 256.0f;

}  // namespace linesight
