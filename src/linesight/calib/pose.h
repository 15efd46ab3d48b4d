// Rigid transforms as 6 doubles: angle-axis rotation (3, radians) then translation (3, metres), so
// that Ceres can optimise them as one parameter block. `b_from_a` maps a point in frame a to frame
// b: X_b = R·X_a + t.
#pragma once

#include <array>

#include <ceres/rotation.h>
#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace linesight::calib {

inline constexpr int kPoseSize = 6;

// X_b = R·X_a + t for a pose block [angle-axis(3), t(3)].
template <typename T>
void TransformPoint(const T* b_from_a, const T* point_a, T* point_b) {
  ceres::AngleAxisRotatePoint(b_from_a, point_a, point_b);
  point_b[0] += b_from_a[3];
  point_b[1] += b_from_a[4];
  point_b[2] += b_from_a[5];
}

struct Pose {
  std::array<double, kPoseSize> params{};  // angle-axis (rad), translation (m)

  Eigen::Matrix3d Rotation() const;
  Eigen::Vector3d Translation() const { return {params[3], params[4], params[5]}; }
  Eigen::Vector3d Apply(const Eigen::Vector3d& point) const {
    return Rotation() * point + Translation();
  }
  Pose Inverse() const;

  static Pose FromRotationTranslation(const Eigen::Matrix3d& rotation,
                                      const Eigen::Vector3d& translation);
  // Rotation 3x3 / translation 3x1 CV_64F.
  cv::Mat RotationMat() const;
  cv::Mat TranslationMat() const;
  static Pose FromOpenCV(const cv::Mat& rotation_or_rvec, const cv::Mat& translation);
};

// c_from_a = c_from_b * b_from_a.
Pose operator*(const Pose& c_from_b, const Pose& b_from_a);

// Nearest rotation matrix (Frobenius norm) with det = +1.
Eigen::Matrix3d NearestRotation(const Eigen::Matrix3d& matrix);

}  // namespace linesight::calib
