// Ceres cost functors shared by the calibrators, the covariance and the Cramér-Rao bound.
#pragma once

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <Eigen/Core>

#include "linesight/calib/camera_model.h"
#include "linesight/calib/pattern.h"
#include "linesight/calib/pose.h"

namespace linesight::calib::detail {

// observed − projection of a camera-frame point (px); false when it does not project.
template <typename T>
bool PixelResidual(const T* intrinsics, const T* camera, const Eigen::Vector2d& observed,
                   T* residual) {
  T pixel[2];
  if (!Project(intrinsics, camera, pixel)) return false;
  residual[0] = pixel[0] - T(observed.x());
  residual[1] = pixel[1] - T(observed.y());
  return true;
}

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
    return PixelResidual(intrinsics, camera, observed_, residual);
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
    return PixelResidual(intrinsics, right, observed_, residual);
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

// recon's board-shape model: a board point displaced along the board normal by the shared
// quadratic bend z = b0·u² + b1·v² + b2·u·v (metres), u, v the point's board coordinates scaled to
// [−1, 1] over the corner grid (BoardBendCoordinates). No constant or linear terms: those are a
// rigid motion of the board, already in every view's pose.
template <typename T>
void BentBoardPoint(const Eigen::Vector3d& board_point, const Eigen::Vector2d& uv, const T* bend,
                    T* point) {
  point[0] = T(board_point.x());
  point[1] = T(board_point.y());
  point[2] = T(board_point.z()) + bend[0] * T(uv.x() * uv.x()) + bend[1] * T(uv.y() * uv.y()) +
             bend[2] * T(uv.x() * uv.y());
}

// ReprojectionResidual on the bent board.
struct BentReprojectionResidual {
  BentReprojectionResidual(const Eigen::Vector2d& observed, const Eigen::Vector3d& board_point,
                           const Eigen::Vector2d& uv)
      : observed_(observed), board_point_(board_point), uv_(uv) {}

  template <typename T>
  bool operator()(const T* intrinsics, const T* camera_from_board, const T* bend,
                  T* residual) const {
    T board[3], camera[3];
    BentBoardPoint(board_point_, uv_, bend, board);
    TransformPoint(camera_from_board, board, camera);
    return PixelResidual(intrinsics, camera, observed_, residual);
  }

  static ceres::CostFunction* Create(const Eigen::Vector2d& observed,
                                     const Eigen::Vector3d& board_point,
                                     const Eigen::Vector2d& uv) {
    return new ceres::AutoDiffCostFunction<BentReprojectionResidual, 2, kNumIntrinsics, kPoseSize,
                                           kBoardBendSize>(
        new BentReprojectionResidual(observed, board_point, uv));
  }

  Eigen::Vector2d observed_;
  Eigen::Vector3d board_point_;
  Eigen::Vector2d uv_;
};

// StereoReprojectionResidual on the bent board.
struct BentStereoReprojectionResidual {
  BentStereoReprojectionResidual(const Eigen::Vector2d& observed,
                                 const Eigen::Vector3d& board_point, const Eigen::Vector2d& uv)
      : observed_(observed), board_point_(board_point), uv_(uv) {}

  template <typename T>
  bool operator()(const T* intrinsics, const T* left_from_board, const T* right_from_left,
                  const T* bend, T* residual) const {
    T board[3], left[3], right[3];
    BentBoardPoint(board_point_, uv_, bend, board);
    TransformPoint(left_from_board, board, left);
    TransformPoint(right_from_left, left, right);
    return PixelResidual(intrinsics, right, observed_, residual);
  }

  static ceres::CostFunction* Create(const Eigen::Vector2d& observed,
                                     const Eigen::Vector3d& board_point,
                                     const Eigen::Vector2d& uv) {
    return new ceres::AutoDiffCostFunction<BentStereoReprojectionResidual, 2, kNumIntrinsics,
                                           kPoseSize, kPoseSize, kBoardBendSize>(
        new BentStereoReprojectionResidual(observed, board_point, uv));
  }

  Eigen::Vector2d observed_;
  Eigen::Vector3d board_point_;
  Eigen::Vector2d uv_;
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

// recon: the weights of one corner seen by both cameras, at the given parameters. A = ∂X̂/∂(left
// pixel, right pixel) (3x4) = ∂X̂/∂(normalised coordinates) · (∂pixel/∂normalised)⁻¹ per camera,
// both factors by central differences in the coordinates (exact derivatives in the parameters);
// C = A·Aᵀ = L·Lᵀ (Cholesky), B = L⁻¹·A, so that P = Aᵀ·C⁻¹·A = Bᵀ·B. Takes the undistorted
// normalised coordinates of both pixels; writes L (lower, row-major 3x3) and B (row-major 3x4).
// False if C is not positive definite (parallel rays) or a distortion Jacobian is singular.
template <typename T>
bool ReconCornerWhitening(const T* left_intrinsics, const T* right_intrinsics,
                          const T* right_from_left, const T* left_normalized,
                          const T* right_normalized, const double noise[2], T* l, T* b) {
  constexpr double kStep = 1e-6;  // in normalised coordinates (~1e-3 px)
  // Pixel -> normalised Jacobians: inverse of f·∂distort/∂n at the undistorted point.
  T normalized_from_pixel[2][2][2];  // [camera][row][col]
  for (int camera = 0; camera < 2; ++camera) {
    const T* intrinsics = camera == 0 ? left_intrinsics : right_intrinsics;
    const T* n = camera == 0 ? left_normalized : right_normalized;
    T pixel_from_normalized[2][2];
    for (int k = 0; k < 2; ++k) {
      T plus[2] = {n[0], n[1]}, minus[2] = {n[0], n[1]};
      plus[k] += T(kStep);
      minus[k] -= T(kStep);
      T xp, yp, xm, ym;
      DistortNormalized(intrinsics, plus[0], plus[1], &xp, &yp);
      DistortNormalized(intrinsics, minus[0], minus[1], &xm, &ym);
      pixel_from_normalized[0][k] = intrinsics[kFx] * (xp - xm) / T(2 * kStep);
      pixel_from_normalized[1][k] = intrinsics[kFy] * (yp - ym) / T(2 * kStep);
    }
    const T determinant = pixel_from_normalized[0][0] * pixel_from_normalized[1][1] -
                          pixel_from_normalized[0][1] * pixel_from_normalized[1][0];
    using std::abs;
    if (!(abs(determinant) > T(1e-12))) return false;
    normalized_from_pixel[camera][0][0] = pixel_from_normalized[1][1] / determinant;
    normalized_from_pixel[camera][0][1] = -pixel_from_normalized[0][1] / determinant;
    normalized_from_pixel[camera][1][0] = -pixel_from_normalized[1][0] / determinant;
    normalized_from_pixel[camera][1][1] = pixel_from_normalized[0][0] / determinant;
  }
  // ∂X̂/∂(left n, right n) (3x4).
  T point_from_normalized[3][4];
  for (int k = 0; k < 4; ++k) {
    T point[2][3];
    for (int side = 0; side < 2; ++side) {
      T shifted_left[2] = {left_normalized[0], left_normalized[1]};
      T shifted_right[2] = {right_normalized[0], right_normalized[1]};
      const T step = T(side == 0 ? kStep : -kStep);
      if (k < 2) {
        shifted_left[k] += step;
      } else {
        shifted_right[k - 2] += step;
      }
      TriangulateMidpointT(shifted_left, shifted_right, right_from_left, point[side]);
    }
    for (int r = 0; r < 3; ++r)
      point_from_normalized[r][k] = (point[0][r] - point[1][r]) / T(2 * kStep);
  }
  T a[3][4];
  for (int r = 0; r < 3; ++r) {
    for (int camera = 0; camera < 2; ++camera) {
      for (int k = 0; k < 2; ++k) {
        a[r][2 * camera + k] =
            (point_from_normalized[r][2 * camera] * normalized_from_pixel[camera][0][k] +
             point_from_normalized[r][2 * camera + 1] * normalized_from_pixel[camera][1][k]) *
            T(noise[camera]);
      }
    }
  }
  T c[3][3];
  for (int r = 0; r < 3; ++r) {
    for (int q = 0; q < 3; ++q) {
      c[r][q] = T(0);
      for (int k = 0; k < 4; ++k) c[r][q] += a[r][k] * a[q][k];
    }
  }
  for (int i = 0; i < 9; ++i) l[i] = T(0);
  for (int j = 0; j < 3; ++j) {
    T diagonal = c[j][j];
    for (int k = 0; k < j; ++k) diagonal -= l[3 * j + k] * l[3 * j + k];
    if (!(diagonal > T(1e-12) * c[j][j]) || !(c[j][j] > T(0))) return false;
    l[3 * j + j] = sqrt(diagonal);
    for (int i = j + 1; i < 3; ++i) {
      T sum = c[i][j];
      for (int k = 0; k < j; ++k) sum -= l[3 * i + k] * l[3 * j + k];
      l[3 * i + j] = sum / l[3 * j + j];
    }
  }
  for (int k = 0; k < 4; ++k) {  // B = L⁻¹·A by forward substitution, column by column
    for (int r = 0; r < 3; ++r) {
      T sum = a[r][k];
      for (int q = 0; q < r; ++q) sum -= l[3 * r + q] * b[4 * q + k];
      b[4 * r + k] = sum / l[3 * r + r];
    }
  }
  return true;
}

// recon: one corner seen by both cameras of a pair view, its information expressed through the 3D
// reconstruction. With e = (e_left, e_right) its four reprojection residuals (px) and Δ = X̂ −
// left_from_board·P the offset of the midpoint triangulation X̂ of its two observed pixels from the
// board point, Δ ≈ −A·e to first order (A = ∂X̂/∂pixels, 3x4), so the covariance of Δ under
// i.i.d. pixel noise σ is σ²·C, C = A·Aᵀ, and the whitened reconstruction error ΔᵀC⁻¹Δ (px², σ
// cancels) equals eᵀ·P·e with P = Aᵀ·C⁻¹·A the projector onto the three directions of pixel space
// the triangulation sees. The residual is
//   [ (I − (1 − sqrt(1 − w²))·P)·e ; w·L⁻¹·Δ ]   (C = L·Lᵀ)
// so its squared norm is eᵀ(I − w²P)e + w²·ΔᵀC⁻¹Δ = |e|² to first order for every w in [0, 1]: the
// reconstruction term replaces the share w² of the reprojection error in the directions it
// measures instead of counting those pixels a second time. A, C and P are evaluated at the current
// parameters inside the cost: with weights frozen at a starting estimate the optimiser shrinks the
// apparent depth noise A·e by moving focal length and board distances along their weakly
// determined direction (fx −1 % at σ = 0.5 px in the simulation).
struct ReconCornerResidual {
  ReconCornerResidual(const Eigen::Vector2d& left_pixel, const Eigen::Vector2d& right_pixel,
                      const Eigen::Vector3d& board_point, const Eigen::Vector2d& uv, double weight,
                      double left_noise = 1.0, double right_noise = 1.0)
      : left_pixel_(left_pixel),
        right_pixel_(right_pixel),
        board_point_(board_point),
        uv_(uv),
        weight_(weight),
        noise_{left_noise, right_noise} {}

  template <typename T>
  bool operator()(const T* left_intrinsics, const T* right_intrinsics, const T* left_from_board,
                  const T* right_from_left, const T* bend, T* residual) const {
    T board[3];
    BentBoardPoint(board_point_, uv_, bend, board);
    T left[3], right[3], left_predicted[2], right_predicted[2];
    TransformPoint(left_from_board, board, left);
    TransformPoint(right_from_left, left, right);
    if (!Project(left_intrinsics, left, left_predicted)) return false;
    if (!Project(right_intrinsics, right, right_predicted)) return false;
    // Residuals in units of each camera's pixel noise (relative scales noise_, 1 = i.i.d.).
    const T e[4] = {(left_predicted[0] - T(left_pixel_.x())) / noise_[0],
                    (left_predicted[1] - T(left_pixel_.y())) / noise_[0],
                    (right_predicted[0] - T(right_pixel_.x())) / noise_[1],
                    (right_predicted[1] - T(right_pixel_.y())) / noise_[1]};
    T left_normalized[2], right_normalized[2], triangulated[3];
    PixelToNormalized(left_intrinsics, left_pixel_, left_normalized);
    PixelToNormalized(right_intrinsics, right_pixel_, right_normalized);
    TriangulateMidpointT(left_normalized, right_normalized, right_from_left, triangulated);
    T l[9], b[12];
    if (!ReconCornerWhitening(left_intrinsics, right_intrinsics, right_from_left, left_normalized,
                              right_normalized, noise_, l, b)) {
      return false;
    }
    // (I − c·BᵀB)·e
    const T c = T(1 - std::sqrt(std::max(0.0, 1 - weight_ * weight_)));
    T be[3];
    for (int r = 0; r < 3; ++r) {
      be[r] = T(0);
      for (int k = 0; k < 4; ++k) be[r] += b[4 * r + k] * e[k];
    }
    for (int k = 0; k < 4; ++k) {
      T projected = T(0);
      for (int r = 0; r < 3; ++r) projected += b[4 * r + k] * be[r];
      residual[k] = e[k] - c * projected;
    }
    // w·L⁻¹·Δ
    for (int r = 0; r < 3; ++r) {
      T sum = triangulated[r] - left[r];
      for (int q = 0; q < r; ++q)
        sum -= l[3 * r + q] * residual[4 + q] / T(weight_ > 0 ? weight_ : 1);
      residual[4 + r] = sum / l[3 * r + r] * T(weight_);
    }
    return true;
  }

  static ceres::CostFunction* Create(const Eigen::Vector2d& left_pixel,
                                     const Eigen::Vector2d& right_pixel,
                                     const Eigen::Vector3d& board_point, const Eigen::Vector2d& uv,
                                     double weight, double left_noise = 1.0,
                                     double right_noise = 1.0) {
    return new ceres::AutoDiffCostFunction<ReconCornerResidual, 7, kNumIntrinsics, kNumIntrinsics,
                                           kPoseSize, kPoseSize, kBoardBendSize>(
        new ReconCornerResidual(left_pixel, right_pixel, board_point, uv, weight, left_noise,
                                right_noise));
  }

  Eigen::Vector2d left_pixel_, right_pixel_;
  Eigen::Vector3d board_point_;
  Eigen::Vector2d uv_;
  double weight_;
  double noise_[2];
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
