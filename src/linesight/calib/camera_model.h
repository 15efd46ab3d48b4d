// Pinhole camera with OpenCV's "plumb_bob" distortion (radial k1 k2 k3, tangential p1 p2) and the
// optional rational model (k4 k5 k6), templated on the scalar type so that Ceres Jets flow through
// it (CONVENTIONS.md §8).
//
// Intrinsic parameter order (kNumIntrinsics = 12 doubles, always stored in full):
//   fx fy cx cy k1 k2 p1 p2 k3 k4 k5 k6
// which is [fx fy cx cy] followed by OpenCV's distortion vector (k1 k2 p1 p2 k3 k4 k5 k6). Unused
// coefficients are zero (and held constant by the optimisers).
//
// Normalised coordinates (x, y) = (X/Z, Y/Z); distorted (xd, yd):
//   r² = x² + y²,  radial = (1 + k1 r² + k2 r⁴ + k3 r⁶) / (1 + k4 r² + k5 r⁴ + k6 r⁶)
//   xd = x·radial + 2 p1 x y + p2 (r² + 2 x²)
//   yd = y·radial + p1 (r² + 2 y²) + 2 p2 x y
//   u = fx·xd + cx,  v = fy·yd + cy
#pragma once

#include <array>
#include <cmath>

#include <opencv2/core.hpp>

namespace linesight::calib {

enum IntrinsicIndex : int {
  kFx = 0,
  kFy,
  kCx,
  kCy,
  kK1,
  kK2,
  kP1,
  kP2,
  kK3,
  kK4,
  kK5,
  kK6,
  kNumIntrinsics
};

// Smallest depth (in the camera frame, same unit as the point) in front of the camera that Project
// accepts.
inline constexpr double kMinProjectDepth = 1e-9;

// Applies the lens distortion to normalised coordinates.
template <typename T>
void DistortNormalized(const T* intrinsics, const T& x, const T& y, T* xd, T* yd) {
  const T x2 = x * x;
  const T y2 = y * y;
  const T xy = x * y;
  const T r2 = x2 + y2;
  const T r4 = r2 * r2;
  const T r6 = r4 * r2;
  const T* k = intrinsics;
  const T radial = (T(1) + k[kK1] * r2 + k[kK2] * r4 + k[kK3] * r6) /
                   (T(1) + k[kK4] * r2 + k[kK5] * r4 + k[kK6] * r6);
  *xd = x * radial + T(2) * k[kP1] * xy + k[kP2] * (r2 + T(2) * x2);
  *yd = y * radial + k[kP1] * (r2 + T(2) * y2) + T(2) * k[kP2] * xy;
}

// Projects a point given in the camera frame to pixels. Returns false (and leaves `pixel` computed
// where possible) when the point is not in front of the camera or the rational denominator is not
// positive.
template <typename T>
bool Project(const T* intrinsics, const T* point_camera, T* pixel) {
  if (!(point_camera[2] > T(kMinProjectDepth))) {
    pixel[0] = T(0);
    pixel[1] = T(0);
    return false;
  }
  const T x = point_camera[0] / point_camera[2];
  const T y = point_camera[1] / point_camera[2];
  const T r2 = x * x + y * y;
  const T denominator =
      T(1) + intrinsics[kK4] * r2 + intrinsics[kK5] * r2 * r2 + intrinsics[kK6] * r2 * r2 * r2;
  T xd, yd;
  DistortNormalized(intrinsics, x, y, &xd, &yd);
  pixel[0] = intrinsics[kFx] * xd + intrinsics[kCx];
  pixel[1] = intrinsics[kFy] * yd + intrinsics[kCy];
  return denominator > T(0);
}

// Removes the distortion from normalised distorted coordinates by fixed-point iteration (as
// cv::undistortPoints does); a fixed iteration count keeps it usable with Jets inside cost
// functions.
template <typename T>
void UndistortNormalizedFixedPoint(const T* intrinsics, const T& xd, const T& yd, T* x, T* y,
                                   int iterations = 20) {
  const T* k = intrinsics;
  T xu = xd;
  T yu = yd;
  for (int i = 0; i < iterations; ++i) {
    const T r2 = xu * xu + yu * yu;
    const T r4 = r2 * r2;
    const T r6 = r4 * r2;
    const T inverse_radial = (T(1) + k[kK4] * r2 + k[kK5] * r4 + k[kK6] * r6) /
                             (T(1) + k[kK1] * r2 + k[kK2] * r4 + k[kK3] * r6);
    const T delta_x = T(2) * k[kP1] * xu * yu + k[kP2] * (r2 + T(2) * xu * xu);
    const T delta_y = k[kP1] * (r2 + T(2) * yu * yu) + T(2) * k[kP2] * xu * yu;
    xu = (xd - delta_x) * inverse_radial;
    yu = (yd - delta_y) * inverse_radial;
  }
  *x = xu;
  *y = yu;
}

// Removes the distortion from normalised distorted coordinates by Newton's method on
// DistortNormalized with its analytic Jacobian, started at (xd, yd); for the distortion of real
// lenses it converges to ~1e-15 in a few iterations. Returns false if the residual stays above
// 1e-12 (x, y then hold the last iterate). The renderer of sim/ casts every ray through it.
inline bool UndistortNormalized(const double* intrinsics, double xd, double yd, double* x_out,
                                double* y_out) {
  const double* k = intrinsics;
  double& x = *x_out;
  double& y = *y_out;
  x = xd;
  y = yd;
  for (int iteration = 0; iteration < 30; ++iteration) {
    double fx, fy;
    DistortNormalized(intrinsics, x, y, &fx, &fy);
    const double ex = fx - xd, ey = fy - yd;
    if (std::fabs(ex) < 1e-15 && std::fabs(ey) < 1e-15) break;
    // Jacobian of DistortNormalized: radial(r²) = numerator / denominator.
    const double r2 = x * x + y * y;
    const double numerator = 1.0 + r2 * (k[kK1] + r2 * (k[kK2] + r2 * k[kK3]));
    const double denominator = 1.0 + r2 * (k[kK4] + r2 * (k[kK5] + r2 * k[kK6]));
    const double radial = numerator / denominator;
    const double dnumerator = k[kK1] + r2 * (2.0 * k[kK2] + 3.0 * r2 * k[kK3]);
    const double ddenominator = k[kK4] + r2 * (2.0 * k[kK5] + 3.0 * r2 * k[kK6]);
    const double dradial_dr2 =
        (dnumerator * denominator - numerator * ddenominator) / (denominator * denominator);
    const double j00 = radial + 2.0 * x * x * dradial_dr2 + 2.0 * k[kP1] * y + 6.0 * k[kP2] * x;
    const double j01 = 2.0 * x * y * dradial_dr2 + 2.0 * k[kP1] * x + 2.0 * k[kP2] * y;
    const double j11 = radial + 2.0 * y * y * dradial_dr2 + 6.0 * k[kP1] * y + 2.0 * k[kP2] * x;
    const double det = j00 * j11 - j01 * j01;
    if (std::fabs(det) < 1e-12) return false;
    x -= (j11 * ex - j01 * ey) / det;
    y -= (-j01 * ex + j00 * ey) / det;
  }
  double fx, fy;
  DistortNormalized(intrinsics, x, y, &fx, &fy);
  return std::fabs(fx - xd) < 1e-12 && std::fabs(fy - yd) < 1e-12;
}

// Pixel -> normalised undistorted coordinates (the ray (x, y, 1)) by UndistortNormalized; returns
// false when the ray does not project back to within `tolerance_px` of the pixel.
bool Unproject(const double* intrinsics, const double* pixel, double* normalized,
               double tolerance_px = 1e-9);

// A camera's intrinsics with conversions to and from OpenCV's K / distortion vector.
struct CameraIntrinsics {
  std::array<double, kNumIntrinsics> params{};

  double fx() const { return params[kFx]; }
  double fy() const { return params[kFy]; }
  double cx() const { return params[kCx]; }
  double cy() const { return params[kCy]; }

  // 3x3 CV_64F camera matrix.
  cv::Mat CameraMatrix() const;
  // 1xN CV_64F distortion vector in OpenCV order (N = 5 for plumb_bob, 8 for rational).
  cv::Mat Distortion(int count) const;
  // From a 3x3 K and a distortion vector of 4, 5, 8 (or more, extra ignored) elements; throws
  // InputError for other shapes or a K with skew.
  static CameraIntrinsics FromOpenCV(const cv::Mat& camera_matrix, const cv::Mat& distortion);
};

}  // namespace linesight::calib
