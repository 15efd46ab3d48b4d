#include "linesight/calib/camera_model.h"

#include <cmath>

#include "linesight/core/error.h"

namespace linesight::calib {

bool Unproject(const double* intrinsics, const double* pixel, double* normalized,
               double tolerance_px) {
  const double xd = (pixel[0] - intrinsics[kCx]) / intrinsics[kFx];
  const double yd = (pixel[1] - intrinsics[kCy]) / intrinsics[kFy];
  UndistortNormalized(intrinsics, xd, yd, &normalized[0], &normalized[1]);
  const double point[3] = {normalized[0], normalized[1], 1.0};
  double predicted[2];
  if (!Project(intrinsics, point, predicted)) return false;
  return std::hypot(predicted[0] - pixel[0], predicted[1] - pixel[1]) < tolerance_px;
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
