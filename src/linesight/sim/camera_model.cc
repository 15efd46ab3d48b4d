#include "linesight/sim/camera_model.h"

#include <cmath>

namespace linesight::sim::detail {

void Distort(const CameraIntrinsics& c, double x, double y, double* xd, double* yd) {
  const double k1 = c.distortion[0], k2 = c.distortion[1], p1 = c.distortion[2],
               p2 = c.distortion[3], k3 = c.distortion[4];
  const double r2 = x * x + y * y;
  const double radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
  *xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
  *yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
}

bool Undistort(const CameraIntrinsics& c, double xd, double yd, double* x_out, double* y_out) {
  const double k1 = c.distortion[0], k2 = c.distortion[1], p1 = c.distortion[2],
               p2 = c.distortion[3], k3 = c.distortion[4];
  double x = xd, y = yd;
  for (int iteration = 0; iteration < 30; ++iteration) {
    double fx, fy;
    Distort(c, x, y, &fx, &fy);
    const double ex = fx - xd, ey = fy - yd;
    if (std::fabs(ex) < 1e-15 && std::fabs(ey) < 1e-15) break;
    // Jacobian of Distort.
    const double r2 = x * x + y * y;
    const double radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
    const double dradial_dr2 = k1 + r2 * (2.0 * k2 + 3.0 * r2 * k3);
    const double j00 = radial + 2.0 * x * x * dradial_dr2 + 2.0 * p1 * y + 6.0 * p2 * x;
    const double j01 = 2.0 * x * y * dradial_dr2 + 2.0 * p1 * x + 2.0 * p2 * y;
    const double j10 = 2.0 * x * y * dradial_dr2 + 2.0 * p1 * x + 2.0 * p2 * y;
    const double j11 = radial + 2.0 * y * y * dradial_dr2 + 6.0 * p1 * y + 2.0 * p2 * x;
    const double det = j00 * j11 - j01 * j10;
    if (std::fabs(det) < 1e-12) return false;
    x -= (j11 * ex - j01 * ey) / det;
    y -= (-j10 * ex + j00 * ey) / det;
  }
  double fx, fy;
  Distort(c, x, y, &fx, &fy);
  *x_out = x;
  *y_out = y;
  return std::fabs(fx - xd) < 1e-12 && std::fabs(fy - yd) < 1e-12;
}

bool ProjectPoint(const CameraIntrinsics& c, Vec3 p, double* u, double* v) {
  if (p.z <= 0) return false;
  double xd, yd;
  Distort(c, p.x / p.z, p.y / p.z, &xd, &yd);
  *u = c.fx * xd + c.cx;
  *v = c.fy * yd + c.cy;
  return true;
}

Vec3 PixelRay(const CameraIntrinsics& c, double u, double v) {
  double x, y;
  Undistort(c, (u - c.cx) / c.fx, (v - c.cy) / c.fy, &x, &y);
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
