#include "linesight/sim/sensor_model.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "linesight/core/error.h"
#include "linesight/sim/procedural_texture.h"

namespace linesight::sim {

void SensorOptions::Check() const {
  CheckOption(supersampling >= 1 && supersampling <= 8, "SensorOptions.supersampling",
              supersampling, "must be in [1, 8]");
  CheckOption(exposure > 0 && exposure <= 100, "SensorOptions.exposure", exposure,
              "must be in (0, 100]");
  CheckOption(right_gain > 0 && right_gain <= 10, "SensorOptions.right_gain", right_gain,
              "must be in (0, 10]");
  CheckOption(gamma >= 1 && gamma <= 3, "SensorOptions.gamma", gamma, "must be in [1, 3]");
  CheckOption(vignetting >= 0 && vignetting <= 0.9, "SensorOptions.vignetting", vignetting,
              "must be in [0, 0.9]");
  CheckOption(blur_sigma_px >= 0 && blur_sigma_px <= 10, "SensorOptions.blur_sigma_px",
              blur_sigma_px, "must be in [0, 10] px");
  CheckOption(noise_sigma_dn >= 0 && noise_sigma_dn <= 64, "SensorOptions.noise_sigma_dn",
              noise_sigma_dn, "must be in [0, 64] DN");
  CheckOption(
      shot_noise_electrons == 0 || (shot_noise_electrons >= 10 && shot_noise_electrons <= 1e7),
      "SensorOptions.shot_noise_electrons", shot_noise_electrons,
      "must be 0 (off) or in [10, 1e7] electrons at full scale");
}

namespace detail {

cv::Mat EncodeSensorImage(const cv::Mat& linear_bgr, const SensorOptions& sensor, double gain,
                          double cx, double cy, std::uint64_t noise_seed) {
  LS_CHECK(linear_bgr.type() == CV_32FC3);
  const int width = linear_bgr.cols, height = linear_bgr.rows;
  cv::Mat exposed(linear_bgr.size(), CV_32FC3);
  // Vignetting normalised so that the farthest image corner from the principal point has r = 1.
  const double corner_x = std::max(cx, width - 1 - cx), corner_y = std::max(cy, height - 1 - cy);
  const double inv_corner2 = 1.0 / (corner_x * corner_x + corner_y * corner_y);
  for (int v = 0; v < height; ++v) {
    const auto* in = linear_bgr.ptr<cv::Vec3f>(v);
    auto* out = exposed.ptr<cv::Vec3f>(v);
    for (int u = 0; u < width; ++u) {
      const double r2 = ((u - cx) * (u - cx) + (v - cy) * (v - cy)) * inv_corner2;
      const double scale = sensor.exposure * gain * (1.0 - sensor.vignetting * r2);
      out[u] = in[u] * static_cast<float>(scale);
    }
  }
  if (sensor.blur_sigma_px > 0) {
    cv::GaussianBlur(exposed, exposed, cv::Size(0, 0), sensor.blur_sigma_px, sensor.blur_sigma_px,
                     cv::BORDER_REFLECT_101);
  }
  NoiseStream noise(noise_seed);
  const double inv_gamma = 1.0 / sensor.gamma;
  const double electrons = sensor.shot_noise_electrons;
  cv::Mat encoded(linear_bgr.size(), CV_8UC3);
  for (int v = 0; v < height; ++v) {
    const auto* in = exposed.ptr<cv::Vec3f>(v);
    auto* out = encoded.ptr<cv::Vec3b>(v);
    for (int u = 0; u < width; ++u) {
      for (int c = 0; c < 3; ++c) {
        double value = std::clamp(static_cast<double>(in[u][c]), 0.0, 1.0);
        if (electrons > 0) {
          const double collected = value * electrons;
          value = std::clamp((collected + std::sqrt(collected) * noise.Gaussian()) / electrons, 0.0,
                             1.0);
        }
        double dn = 255.0 * std::pow(value, inv_gamma);
        if (sensor.noise_sigma_dn > 0) dn += sensor.noise_sigma_dn * noise.Gaussian();
        out[u][c] = static_cast<unsigned char>(std::clamp(std::lround(dn), 0L, 255L));
      }
    }
  }
  return encoded;
}

}  // namespace detail
}  // namespace linesight::sim
