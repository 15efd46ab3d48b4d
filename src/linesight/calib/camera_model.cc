#include "linesight/calib/camera_model.h"

#include <cmath>

#include <Eigen/Dense>

#include "linesight/core/error.h"

namespace linesight::calib {

bool Unproject(const double* intrinsics, const double* pixel, double* normalized,
               double tolerance_px) {
  const double xd = (pixel[0] - intrinsics[kCx]) / intrinsics[kFx];
  const double yd = (pixel[1] - intrinsics[kCy]) / intrinsics[kFy];
  double x, y;
  UndistortNormalizedFixedPoint(intrinsics, xd, yd, &x, &y, 10);
  // Gauss-Newton on pixel(x, y) = observed, with a central-difference Jacobian of the forward
  // model.
  bool converged = false;
  for (int iteration = 0; iteration < 20; ++iteration) {
    double point[3] = {x, y, 1.0};
    double predicted[2];
    Project(intrinsics, point, predicted);
    const Eigen::Vector2d residual(predicted[0] - pixel[0], predicted[1] - pixel[1]);
    if (residual.norm() < tolerance_px) {
      converged = true;
      break;
    }
    Eigen::Matrix2d jacobian;
    for (int c = 0; c < 2; ++c) {
      const double h = 1e-7;
      double plus[3] = {x, y, 1.0};
      double minus[3] = {x, y, 1.0};
      plus[c] += h;
      minus[c] -= h;
      double p_plus[2], p_minus[2];
      Project(intrinsics, plus, p_plus);
      Project(intrinsics, minus, p_minus);
      jacobian(0, c) = (p_plus[0] - p_minus[0]) / (2 * h);
      jacobian(1, c) = (p_plus[1] - p_minus[1]) / (2 * h);
    }
    const Eigen::Vector2d step = jacobian.partialPivLu().solve(residual);
    if (!step.allFinite()) break;
    x -= step[0];
    y -= step[1];
  }
  normalized[0] = x;
  normalized[1] = y;
  if (!converged) {
    double point[3] = {x, y, 1.0};
    double predicted[2];
    Project(intrinsics, point, predicted);
    converged = std::hypot(predicted[0] - pixel[0], predicted[1] - pixel[1]) < tolerance_px;
  }
  return converged;
}

cv::Mat CameraIntrinsics::CameraMatrix() const {
  cv::Mat k = cv::Mat::eye(3, 3, CV_64F);
  k.at<double>(0, 0) = params[kFx];
  k.at<double>(1, 1) = params[kFy];
  k.at<double>(0, 2) = params[kCx];
  k.at<double>(1, 2) = params[kCy];
  return k;
}

cv::Mat CameraIntrinsics::Distortion(int count) const {
  LS_CHECK(count >= 4 && count <= 8);
  cv::Mat d(1, count, CV_64F);
  for (int i = 0; i < count; ++i) d.at<double>(0, i) = params[kK1 + i];
  return d;
}

CameraIntrinsics CameraIntrinsics::FromOpenCV(const cv::Mat& camera_matrix,
                                              const cv::Mat& distortion) {
  if (camera_matrix.rows != 3 || camera_matrix.cols != 3) {
    throw InputError(fmt::format("camera matrix must be 3x3, got {}x{}", camera_matrix.rows,
                                 camera_matrix.cols));
  }
  cv::Mat k;
  camera_matrix.convertTo(k, CV_64F);
  if (std::abs(k.at<double>(0, 1)) > 1e-9 * std::abs(k.at<double>(0, 0))) {
    throw InputError("camera matrix has a non-zero skew, which this camera model does not support");
  }
  CameraIntrinsics out;
  out.params[kFx] = k.at<double>(0, 0);
  out.params[kFy] = k.at<double>(1, 1);
  out.params[kCx] = k.at<double>(0, 2);
  out.params[kCy] = k.at<double>(1, 2);
  cv::Mat d;
  distortion.convertTo(d, CV_64F);
  d = d.reshape(1, 1);
  const int n = static_cast<int>(d.total());
  if (n != 0 && n != 4 && n != 5 && n < 8) {
    throw InputError(fmt::format("distortion vector must have 4, 5 or 8 elements, got {}", n));
  }
  for (int i = 0; i < std::min(n, 8); ++i) out.params[kK1 + i] = d.at<double>(0, i);
  return out;
}

}  // namespace linesight::calib
