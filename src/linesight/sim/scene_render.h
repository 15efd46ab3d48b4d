// Internal to the sim module: shading and the per-pixel render loops shared by the power-line
// scene and the calibration boards.
#pragma once

#include <cstdint>

#include <opencv2/core.hpp>

#include "linesight/sim/camera_model.h"
#include "linesight/sim/power_line_scene.h"
#include "linesight/sim/ray_tracing.h"

namespace linesight::sim::detail {

struct ShadingEnvironment {
  Vec3 up{0, -1, 0};          // world "up" (against gravity), unit
  Vec3 to_sun{0, -0.7, 0.7};  // unit direction towards the sun
  double ambient = 0.35;      // sky ambient relative to the sun
  bool sky = true;            // sky gradient and clouds where nothing is hit (else `backdrop`)
  double cloud_cover = 0.45;  // 0..1
  Vec3 backdrop{0.2, 0.2, 0.2};
  std::uint64_t seed = 1;  // texture variation
  // Stranded cable texture.
  int conductor_strands = 18;
  double conductor_lay_length_m = 0.3;
  // Chessboard: inner corners and square size; the board rectangle's local frame has its origin at
  // the first inner corner.
  int board_cols = 9, board_rows = 6;
  double board_square_m = 0.04;
};

struct RenderScene {
  RayScene geometry;
  ShadingEnvironment environment;
};

// Linear RGB radiance (x = red, y = green, z = blue) seen along `ray` that produced `hit`.
Vec3 Shade(const RenderScene& scene, const Ray& ray, const Hit& hit);

// Renders a camera with S x S supersampling into linear BGR (CV_32FC3). `intrinsics` may have zero
// distortion (rectified cameras).
cv::Mat RenderLinearImage(const RenderScene& scene, const CameraIntrinsics& intrinsics,
                          const PosedCamera& camera, cv::Size size, int supersampling);

// Ground truth through a pinhole camera (no distortion), one ray per pixel centre inside `roi`:
// depth = Z in the camera frame (+inf where nothing is hit), the shape's surface class and obstacle
// id, and when `defect_id` is given the shape's defect id. Outputs are allocated at `size`
// (CV_32FC1, CV_8UC1, CV_8UC1, CV_8UC1) and filled inside `roi` only; outside it depth is +inf and
// the labels 0.
void TraceGroundTruth(const RenderScene& scene, const CameraIntrinsics& pinhole,
                      const PosedCamera& camera, cv::Size size, cv::Rect roi, cv::Mat* depth,
                      cv::Mat* surface_class, cv::Mat* obstacle_id, cv::Mat* defect_id = nullptr);

}  // namespace linesight::sim::detail
