#include "linesight/sim/camera_model.h"

#include <cmath>

namespace linesight::sim::detail {

std::array<double, calib::kNumIntrinsics> PlumbBobIntrinsics(const CameraIntrinsics& c) {
  std::array<double, calib::kNumIntrinsics> k{};
  k[calib::kFx] = c.fx;
  k[calib::kFy] = c.fy;
  k[calib::kCx] = c.cx;
  k[calib::kCy] = c.cy;
  // OpenCV's order on both sides: k1 k2 p1 p2 k3.
  for (size_t i = 0; i < c.distortion.size(); ++i) k[calib::kK1 + i] = c.distortion[i];
  return k;
}

bool ProjectPoint(const CameraIntrinsics& c, Vec3 p, double* u, double* v) {
  if (p.z <= 0) return false;
  const std::array<double, calib::kNumIntrinsics> k = PlumbBobIntrinsics(c);
  double xd, yd;
  calib::DistortNormalized(k.data(), p.x / p.z, p.y / p.z, &xd, &yd);
  *u = c.fx * xd + c.cx;
  *v = c.fy * yd + c.cy;
  return true;
}

Vec3 PixelRay(const CameraIntrinsics& c, double u, double v) {
  const std::array<double, calib::kNumIntrinsics> k = PlumbBobIntrinsics(c);
  double x, y;
  calib::UndistortNormalized(k.data(), (u - c.cx) / c.fx, (v - c.cy) / c.fy, &x, &y);
  return Normalized({x, y, 1.0});
}

PosedCamera PosedCamera::FromRt(const Mat3& rotation, Vec3 translation) {
  PosedCamera camera;
  camera.camera_from_scene = rotation;
  camera.translation = translation;
  camera.centre = -rotation.ApplyTransposed(translation);
  return camera;
}

Ray PosedCamera::RayThrough(Vec3 direction_in_camera) const {
  return {centre, camera_from_scene.ApplyTransposed(direction_in_camera)};
}

}  // namespace linesight::sim::detail
