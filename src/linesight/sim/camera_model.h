// Internal to the sim module: the plumb-bob (Brown-Conrady) camera model of OpenCV, forwards and
// inverted to machine precision, so that rendered images agree with cv::projectPoints.
#pragma once

#include "linesight/sim/power_line_scene.h"
#include "linesight/sim/ray_tracing.h"

namespace linesight::sim::detail {

// Normalised undistorted (x, y) -> normalised distorted coordinates (OpenCV k1 k2 p1 p2 k3 order).
void Distort(const CameraIntrinsics& camera, double x, double y, double* xd, double* yd);

// Inverse of Distort by Newton iterations (converges to ~1e-15 for the distortion of real lenses);
// returns false if it did not converge.
bool Undistort(const CameraIntrinsics& camera, double xd, double yd, double* x, double* y);

// Projects a point in the camera frame to raw pixel coordinates; false if it is behind the camera.
bool ProjectPoint(const CameraIntrinsics& camera, Vec3 point, double* u, double* v);

// Unit ray direction in the camera frame through raw pixel (u, v).
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
