// Synthetic rectified disparity maps with exact ground truth for the ranging tests.
#pragma once

#include <cmath>
#include <random>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "linesight/core/disparity.h"
#include "linesight/geometry/depth.h"

namespace linesight::testing {

// A rig like the MYNT S1030 after rectification, on a 320x240 crop.
inline StereoGeometry TestGeometry() {
  StereoGeometry g;
  g.focal_px = 736.0;
  g.baseline_m = 0.119;
  g.cx = 160.0;
  g.cy = 120.0;
  return g;
}

// Correlated matching noise: white noise blurred over ~3 px, scaled to `sigma` px.
inline cv::Mat CorrelatedNoise(cv::Size size, double sigma, unsigned seed) {
  cv::Mat noise(size, CV_32F);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::NORMAL, 0.0, 1.0);
  cv::GaussianBlur(noise, noise, {0, 0}, 1.5);
  cv::Scalar mean, stddev;
  cv::meanStdDev(noise, mean, stddev);
  return noise * (sigma / stddev[0]);
}

// Scene: a wall far behind (outside any working range), a background plane at `background_m` in the
// lower part, a conductor ramp crossing the image, and a sphere of `radius_m` whose nearest surface
// is at `distance_m` straight ahead of pixel `centre`. Returns the disparity; `sphere_box` receives
// the sphere's box.
inline cv::Mat SphereScene(const StereoGeometry& g, double distance_m, double radius_m,
                           cv::Point centre, double background_m, double noise_px, unsigned seed,
                           cv::Rect* sphere_box) {
  cv::Mat d(240, 320, CV_32F);
  const double fb = g.focal_px * g.baseline_m;
  // Sphere centre on the ray through `centre`, at depth distance + radius along that ray's Z: the
  // nearest point along the optical axis is then (approximately, for small angles) at `distance_m`.
  const cv::Vec3d ray((centre.x - g.cx) / g.focal_px, (centre.y - g.cy) / g.focal_px, 1.0);
  const cv::Vec3d c = ray * (distance_m + radius_m);
  int x0 = 1 << 30, y0 = 1 << 30, x1 = -1, y1 = -1;
  for (int y = 0; y < d.rows; ++y) {
    for (int x = 0; x < d.cols; ++x) {
      double z = 30.0;  // far wall
      if (y > 170) z = background_m;
      // Conductor: a band 6 px wide from the lower left, disparity growing towards the bottom.
      const double along = (x - 0.3 * y);
      if (std::abs(along - 40.0) < 3.0 && y > 20)
        z = std::min(z, 0.9 * distance_m + 0.01 * (240 - y));
      const cv::Vec3d v((x - g.cx) / g.focal_px, (y - g.cy) / g.focal_px, 1.0);
      // Ray-sphere intersection: |t v - c|^2 = r^2.
      const double a = v.dot(v), b = -2.0 * v.dot(c), cc = c.dot(c) - radius_m * radius_m;
      const double disc = b * b - 4 * a * cc;
      if (disc >= 0) {
        const double t = (-b - std::sqrt(disc)) / (2 * a);
        if (t > 0 && t < z) {
          z = t;
          x0 = std::min(x0, x), y0 = std::min(y0, y), x1 = std::max(x1, x), y1 = std::max(y1, y);
        }
      }
      d.at<float>(y, x) = float(fb / z);
    }
  }
  if (sphere_box) *sphere_box = cv::Rect(x0, y0, x1 - x0 + 1, y1 - y0 + 1);
  if (noise_px > 0) d += CorrelatedNoise(d.size(), noise_px, seed);
  // Sky-like holes: a few invalid pixels.
  cv::RNG rng(seed + 1);
  for (int i = 0; i < 200; ++i)
    d.at<float>(rng.uniform(0, 240), rng.uniform(0, 320)) = kInvalidDisparity;
  return d;
}

}  // namespace linesight::testing
