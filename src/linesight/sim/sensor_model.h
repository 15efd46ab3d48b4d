// Internal to the sim module: turns rendered linear radiance into 8-bit camera images.
#pragma once

#include <cstdint>

#include <opencv2/core.hpp>

#include "linesight/sim/power_line_scene.h"

namespace linesight::sim::detail {

// linear_bgr: CV_32FC3 scene radiance (1.0 = full scale at exposure 1). Applies exposure * gain,
// vignetting around (cx, cy), Gaussian blur, shot noise, gamma encoding and read noise, then
// rounds to CV_8UC3. Deterministic in `noise_seed`.
cv::Mat EncodeSensorImage(const cv::Mat& linear_bgr, const SensorOptions& sensor, double gain,
                          double cx, double cy, std::uint64_t noise_seed);

}  // namespace linesight::sim::detail
