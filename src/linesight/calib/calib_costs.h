// Ceres cost functors shared by the calibrators, the covariance and the Cramér-Rao bound.
#pragma once

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <Eigen/Core>

#include "linesight/calib/camera_model.h"
#include "linesight/calib/pose.h"

namespace linesight::calib::detail {

// Pixel residual (predicted − observed) of a board point seen by a camera with pose
// camera_from_board.
struct ReprojectionResidual {
  ReprojectionResidual(const Eigen::Vector2d& observed, const Eigen::Vector3d& board_point)
      : observed_(observed), board_point_(board_point) {}

  template <typename T>
  bool operator()(const T* intrinsics, const T* camera_from_board, T* residual) const {
    const T board[3] = {T(board_point_.x()), T(board_point_.y()), T(board_point_.z())};
    T camera[3];
    TransformPoint(camera_from_board, board, camera);
    T pixel[2];
    if (!Project(intrinsics, camera, pixel)) return false;
    residual[0] = pixel[0] - T(observed_.x());
    residual[1] = pixel[1] - T(observed_.y());
    return true;
  }

  static ceres::CostFunction* Create(const Eigen::Vector2d& observed,
                                     const Eigen::Vector3d& board_point) {
    return new ceres::AutoDiffCostFunction<ReprojectionResidual, 2, kNumIntrinsics, kPoseSize>(
        new ReprojectionResidual(observed, board_point));
  }

  Eigen::Vector2d observed_;
  Eigen::Vector3d board_point_;
};

// The same for the right camera of a pair view: right_from_board = right_from_left ·
// left_from_board.
struct StereoReprojectionResidual {
  StereoReprojectionResidual(const Eigen::Vector2d& observed, const Eigen::Vector3d& board_point)
      : observed_(observed), board_point_(board_point) {}

  template <typename T>
  bool operator()(const T* intrinsics, const T* left_from_board, const T* right_from_left,
                  T* residual) const {
    const T board[3] = {T(board_point_.x()), T(board_point_.y()), T(board_point_.z())};
    T left[3], right[3];
    TransformPoint(left_from_board, board, left);
    TransformPoint(right_from_left, left, right);
    T pixel[2];
    if (!Project(intrinsics, right, pixel)) return false;
    residual[0] = pixel[0] - T(observed_.x());
    residual[1] = pixel[1] - T(observed_.y());
    return true;
  }

  static ceres::CostFunction* Create(const Eigen::Vector2d& observed,
                                     const Eigen::Vector3d& board_point) {
    return new ceres::AutoDiffCostFunction<StereoReprojectionResidual, 2, kNumIntrinsics, kPoseSize,
                                           kPoseSize>(
        new StereoReprojectionResidual(observed, board_point));
  }

  Eigen::Vector2d observed_;
  Eigen::Vector3d board_point_;
};

// Pixel -> normalised undistorted coordinates with the scalar type of the parameters.
template <typename T>
void PixelToNormalized(const T* intrinsics, const Eigen::Vector2d& pixel, T* normalized) {
  const T xd = (T(pixel.x()) - intrinsics[kCx]) / intrinsics[kFx];
  const T yd = (T(pixel.y()) - intrinsics[kCy]) / intrinsics[kFy];
  UndistortNormalizedFixedPoint(intrinsics, xd, yd, &normalized[0], &normalized[1], 20);
}

// Midpoint of the shortest segment between the left ray (0, d1) and the right ray, in the left
// frame.
template <typename T>
void TriangulateMidpointT(const T* left_normalized, const T* right_normalized,
                          const T* right_from_left, T* point) {
  const T inverse_rotation[3] = {-right_from_left[0], -right_from_left[1], -right_from_left[2]};
  const T translation[3] = {right_from_left[3], right_from_left[4], right_from_left[5]};
  T centre[3];  // right camera centre in the left frame: −Rᵀ·T
  ceres::AngleAxisRotatePoint(inverse_rotation, translation, centre);
  for (T& c : centre) c = -c;
  const T right_ray[3] = {right_normalized[0], right_normalized[1], T(1)};
  T d2[3];
  ceres::AngleAxisRotatePoint(inverse_rotation, right_ray, d2);
  const T d1[3] = {left_normalized[0], left_normalized[1], T(1)};
  const T w0[3] = {-centre[0], -centre[1], -centre[2]};
  const T a = d1[0] * d1[0] + d1[1] * d1[1] + d1[2] * d1[2];
  const T b = d1[0] * d2[0] + d1[1] * d2[1] + d1[2] * d2[2];
  const T c = d2[0] * d2[0] + d2[1] * d2[1] + d2[2] * d2[2];
  const T d = d1[0] * w0[0] + d1[1] * w0[1] + d1[2] * w0[2];
  const T e = d2[0] * w0[0] + d2[1] * w0[1] + d2[2] * w0[2];
  const T denominator = a * c - b * b;
  const T s = (b * e - c * d) / denominator;
  const T t = (a * e - b * d) / denominator;
  for (int k = 0; k < 3; ++k) point[k] = T(0.5) * (s * d1[k] + centre[k] + t * d2[k]);
}

// recon: scaled difference between the triangulated corner and the board point in the left frame.
struct ReconstructionPointResidual {
  ReconstructionPointResidual(const Eigen::Vector2d& left_pixel, const Eigen::Vector2d& right_pixel,
                              const Eigen::Vector3d& board_point, double weight)
      : left_pixel_(left_pixel),
        right_pixel_(right_pixel),
        board_point_(board_point),
        weight_(weight) {}

  template <typename T>
  bool operator()(const T* left_intrinsics, const T* right_intrinsics, const T* left_from_board,
                  const T* right_from_left, T* residual) const {
    T left_normalized[2], right_normalized[2], triangulated[3];
    PixelToNormalized(left_intrinsics, left_pixel_, left_normalized);
    PixelToNormalized(right_intrinsics, right_pixel_, right_normalized);
    TriangulateMidpointT(left_normalized, right_normalized, right_from_left, triangulated);
    const T board[3] = {T(board_point_.x()), T(board_point_.y()), T(board_point_.z())};
    T expected[3];
    TransformPoint(left_from_board, board, expected);
    // Pixel-equivalent units with the current focal length and baseline, split along and across the
    // left viewing ray: the error across the ray is a lateral image error (f/D), the error along it
    // a disparity error (f·B/D²). The split keeps the depth noise (large, along the ray) out of the
    // lateral part, and the current f and B keep the residual's spread independent of the
    // parameters; without either the optimiser lowers the term by biasing f and B instead of
    // fitting the data.
    const T focal = left_intrinsics[kFx];
    const T baseline =
        sqrt(right_from_left[3] * right_from_left[3] + right_from_left[4] * right_from_left[4] +
             right_from_left[5] * right_from_left[5]);
    const T range =
        sqrt(expected[0] * expected[0] + expected[1] * expected[1] + expected[2] * expected[2]);
    T difference[3], along = T(0);
    for (int k = 0; k < 3; ++k) {
      difference[k] = triangulated[k] - expected[k];
      along += difference[k] * expected[k] / range;
    }
    for (int k = 0; k < 3; ++k) {
      residual[k] = T(weight_) * focal * (difference[k] - along * expected[k] / range) / range;
    }
    residual[3] = T(weight_) * focal * baseline * along / (range * range);
    return true;
  }

  static ceres::CostFunction* Create(const Eigen::Vector2d& left_pixel,
                                     const Eigen::Vector2d& right_pixel,
                                     const Eigen::Vector3d& board_point, double weight) {
    return new ceres::AutoDiffCostFunction<ReconstructionPointResidual, 4, kNumIntrinsics,
                                           kNumIntrinsics, kPoseSize, kPoseSize>(
        new ReconstructionPointResidual(left_pixel, right_pixel, board_point, weight));
  }

  Eigen::Vector2d left_pixel_, right_pixel_;
  Eigen::Vector3d board_point_;
  double weight_;
};

// recon: scaled error of the distance between two triangulated adjacent corners.
struct ReconstructionDistanceResidual {
  ReconstructionDistanceResidual(const Eigen::Vector2d& left_a, const Eigen::Vector2d& right_a,
                                 const Eigen::Vector2d& left_b, const Eigen::Vector2d& right_b,
                                 double true_distance, double scale)
      : left_a_(left_a),
        right_a_(right_a),
        left_b_(left_b),
        right_b_(right_b),
        true_distance_(true_distance),
        scale_(scale) {}

  template <typename T>
  bool operator()(const T* left_intrinsics, const T* right_intrinsics, const T* right_from_left,
                  T* residual) const {
    T la[2], ra[2], lb[2], rb[2], a[3], b[3];
    PixelToNormalized(left_intrinsics, left_a_, la);
    PixelToNormalized(right_intrinsics, right_a_, ra);
    PixelToNormalized(left_intrinsics, left_b_, lb);
    PixelToNormalized(right_intrinsics, right_b_, rb);
    TriangulateMidpointT(la, ra, right_from_left, a);
    TriangulateMidpointT(lb, rb, right_from_left, b);
    const T dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
    residual[0] = T(scale_) * (sqrt(dx * dx + dy * dy + dz * dz) - T(true_distance_));
    return true;
  }

  static ceres::CostFunction* Create(const Eigen::Vector2d& left_a, const Eigen::Vector2d& right_a,
                                     const Eigen::Vector2d& left_b, const Eigen::Vector2d& right_b,
                                     double true_distance, double scale) {
    return new ceres::AutoDiffCostFunction<ReconstructionDistanceResidual, 1, kNumIntrinsics,
                                           kNumIntrinsics, kPoseSize>(
        new ReconstructionDistanceResidual(left_a, right_a, left_b, right_b, true_distance, scale));
  }

  Eigen::Vector2d left_a_, right_a_, left_b_, right_b_;
  double true_distance_, scale_;
};

}  // namespace linesight::calib::detail
