// Paths and constants shared by the eval module's tests.
#pragma once

#include <filesystem>
#include <limits>

namespace linesight::test {

// ../shared/data (public stereo datasets) and Debian opencv-doc's example data, as configured by
// CMake.
inline const std::filesystem::path kSharedData = LINESIGHT_SHARED_DATA_DIR;
inline const std::filesystem::path kOpenCvData = LINESIGHT_OPENCV_DATA_DIR;

inline constexpr float kInf = std::numeric_limits<float>::infinity();

}  // namespace linesight::test
