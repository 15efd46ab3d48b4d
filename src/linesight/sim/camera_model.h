// Internal to the sim module: cameras of the renderer. Their lens model is the plumb-bob model of
// calib/camera_model.h (the one the calibrator estimates), so that rendered images agree with
// cv::projectPoints and the calibration of rendered boards has an exact answer.
#pragma once

#include <array>

#include "linesight/calib/camera_model.h"
#include "linesight/sim/power_line_scene.h"
#include "linesight/sim/ray_tracing.h"

namespace linesight::sim::detail {

// `camera` in calib's parameter order (fx fy cx cy k1 k2 p1 p2 k3, no rational terms).
std::array<double, calib::kNumIntrinsics> PlumbBobIntrinsics(const CameraIntrinsics& camera);

// Projects a point in the camera frame to raw pixel coordinates; false if it is behind the camera.
bool ProjectPoint(const CameraIntrinsics& camera, Vec3 point, double* u, double* v);

// Unit ray direction in the camera frame through raw pixel (u, v) (calib::UndistortNormalized:
// Newton iterations to ~1e-15 in normalised coordinates).
Vec3 PixelRay(const CameraIntrinsics& camera, double u, double v);

// A camera placed in the scene (left raw frame): X_camera = rotation * X_scene + translation.
struct PosedCamera {
  Mat3 camera_from_scene;
  Vec3 translation;
  Vec3 centre;  // camera centre in the scene frame

  static PosedCamera FromRt(const Mat3& rotation, Vec3 translation);
  Ray RayThrough(Vec3 direction_in_camera) const;  // scene-frame ray from the centre
};

}  // namespace linesight::sim::detail
