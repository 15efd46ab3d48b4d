#include "linesight/calib/pose.h"

#include <Eigen/Dense>
#include <opencv2/calib3d.hpp>

namespace linesight::calib {

Eigen::Matrix3d Pose::Rotation() const {
  double r[9];
  ceres::AngleAxisToRotationMatrix(params.data(), ceres::ColumnMajorAdapter3x3(r));
  return Eigen::Map<const Eigen::Matrix3d>(r);  // column-major storage matches Eigen's default
}

Pose Pose::Inverse() const {
  const Eigen::Matrix3d r = Rotation();
  return FromRotationTranslation(r.transpose(), -(r.transpose() * Translation()));
}

Pose Pose::FromRotationTranslation(const Eigen::Matrix3d& rotation,
                                   const Eigen::Vector3d& translation) {
  Pose pose;
  const Eigen::Matrix3d r = NearestRotation(rotation);
  ceres::RotationMatrixToAngleAxis(ceres::ColumnMajorAdapter3x3(r.data()), pose.params.data());
  pose.params[3] = translation[0];
  pose.params[4] = translation[1];
  pose.params[5] = translation[2];
  return pose;
}

cv::Mat Pose::RotationMat() const {
  const Eigen::Matrix3d r = Rotation();
  cv::Mat out(3, 3, CV_64F);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) out.at<double>(i, j) = r(i, j);
  return out;
}

cv::Mat Pose::TranslationMat() const {
  return (cv::Mat_<double>(3, 1) << params[3], params[4], params[5]);
}

Pose Pose::FromOpenCV(const cv::Mat& rotation_or_rvec, const cv::Mat& translation) {
  cv::Mat r;
  rotation_or_rvec.convertTo(r, CV_64F);
  if (r.total() == 3) {
    cv::Mat m;
    cv::Rodrigues(r.reshape(1, 3), m);
    r = m;
  }
  cv::Mat t;
  translation.convertTo(t, CV_64F);
  Eigen::Matrix3d rotation;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) rotation(i, j) = r.at<double>(i, j);
  const double* tp = t.ptr<double>();
  return FromRotationTranslation(rotation, Eigen::Vector3d(tp[0], tp[1], tp[2]));
}

Pose operator*(const Pose& c_from_b, const Pose& b_from_a) {
  const Eigen::Matrix3d r = c_from_b.Rotation() * b_from_a.Rotation();
  const Eigen::Vector3d t = c_from_b.Rotation() * b_from_a.Translation() + c_from_b.Translation();
  return Pose::FromRotationTranslation(r, t);
}

Eigen::Matrix3d NearestRotation(const Eigen::Matrix3d& matrix) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(matrix, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  return svd.matrixU() * d * svd.matrixV().transpose();
}

}  // namespace linesight::calib
