#include "linesight/calib/zhang.h"

#include <cmath>

#include <Eigen/Dense>

#include "linesight/core/error.h"

namespace linesight::calib {
namespace {

// Similarity T with T·(x, y, 1) centred at the origin and at mean distance √2.
Eigen::Matrix3d NormalizingTransform(const std::vector<Eigen::Vector2d>& points) {
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
  for (const auto& p : points) centroid += p;
  centroid /= static_cast<double>(points.size());
  double mean_distance = 0;
  for (const auto& p : points) mean_distance += (p - centroid).norm();
  mean_distance /= static_cast<double>(points.size());
  const double scale = mean_distance > 0 ? std::sqrt(2.0) / mean_distance : 1.0;
  Eigen::Matrix3d t = Eigen::Matrix3d::Identity();
  t(0, 0) = t(1, 1) = scale;
  t(0, 2) = -scale * centroid.x();
  t(1, 2) = -scale * centroid.y();
  return t;
}

Eigen::Matrix<double, 1, 6> ConstraintRow(const Eigen::Matrix3d& h, int i, int j) {
  Eigen::Matrix<double, 1, 6> v;
  v << h(0, i) * h(0, j), h(0, i) * h(1, j) + h(1, i) * h(0, j), h(1, i) * h(1, j),
      h(2, i) * h(0, j) + h(0, i) * h(2, j), h(2, i) * h(1, j) + h(1, i) * h(2, j),
      h(2, i) * h(2, j);
  return v;
}

}  // namespace

Eigen::Matrix3d EstimateHomography(const std::vector<Eigen::Vector2d>& board_xy,
                                   const std::vector<Eigen::Vector2d>& pixels) {
  LS_CHECK(board_xy.size() == pixels.size() && board_xy.size() >= 4);
  const Eigen::Matrix3d t_board = NormalizingTransform(board_xy);
  const Eigen::Matrix3d t_pixel = NormalizingTransform(pixels);
  const int n = static_cast<int>(board_xy.size());
  Eigen::MatrixXd a(2 * n, 9);
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d x = t_board * board_xy[i].homogeneous();
    const Eigen::Vector3d u = t_pixel * pixels[i].homogeneous();
    a.row(2 * i) << x.x(), x.y(), 1, 0, 0, 0, -u.x() * x.x(), -u.x() * x.y(), -u.x();
    a.row(2 * i + 1) << 0, 0, 0, x.x(), x.y(), 1, -u.y() * x.x(), -u.y() * x.y(), -u.y();
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(a, Eigen::ComputeFullV);
  const Eigen::VectorXd h = svd.matrixV().col(8);
  Eigen::Matrix3d hn;
  hn << h[0], h[1], h[2], h[3], h[4], h[5], h[6], h[7], h[8];
  Eigen::Matrix3d out = t_pixel.inverse() * hn * t_board;
  return out / out(2, 2);
}

ClosedFormIntrinsics IntrinsicsFromHomographies(const std::vector<Eigen::Matrix3d>& homographies,
                                                cv::Size image_size, const std::string& camera_name,
                                                double min_conditioning) {
  if (homographies.size() < 2) {
    throw InputError(fmt::format("{}: {} usable views, need at least 2 for the closed form",
                                 camera_name, homographies.size()));
  }
  // Work in pixel coordinates normalised by the image size so that V is well conditioned;
  // N has zero skew, so the constraint B12 = 0 carries over.
  const double scale = 1.0 / (0.5 * (image_size.width + image_size.height));
  Eigen::Matrix3d n = Eigen::Matrix3d::Identity();
  n(0, 0) = n(1, 1) = scale;
  n(0, 2) = -0.5 * image_size.width * scale;
  n(1, 2) = -0.5 * image_size.height * scale;
  const int views = static_cast<int>(homographies.size());
  Eigen::MatrixXd v(2 * views + 1, 6);
  for (int i = 0; i < views; ++i) {
    Eigen::Matrix3d h = n * homographies[i];
    h /= h.norm();
    Eigen::Matrix<double, 1, 6> r0 = ConstraintRow(h, 0, 1);
    Eigen::Matrix<double, 1, 6> r1 = ConstraintRow(h, 0, 0) - ConstraintRow(h, 1, 1);
    v.row(2 * i) = r0 / std::max(r0.norm(), 1e-300);
    v.row(2 * i + 1) = r1 / std::max(r1.norm(), 1e-300);
  }
  v.row(2 * views) << 0, 1, 0, 0, 0, 0;  // zero skew: B12 = 0
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(v, Eigen::ComputeFullV);
  const Eigen::VectorXd sv = svd.singularValues();
  ClosedFormIntrinsics out;
  out.conditioning = sv.size() >= 5 ? sv[4] / sv[0] : 0.0;
  const auto degenerate = [&](const std::string& why) {
    return InputError(
        fmt::format("{}: degenerate board poses ({}); the views must show the board at different "
                    "tilts, not all "
                    "parallel",
                    camera_name, why));
  };
  if (!(out.conditioning >= min_conditioning)) {
    throw degenerate(
        fmt::format("closed-form constraints nearly rank-deficient, conditioning {:.2e} < {:.1e}",
                    out.conditioning, min_conditioning));
  }
  Eigen::VectorXd b = svd.matrixV().col(5);
  if (b[0] < 0) b = -b;
  const double b11 = b[0], b12 = b[1], b22 = b[2], b13 = b[3], b23 = b[4], b33 = b[5];
  const double denominator = b11 * b22 - b12 * b12;
  if (!(b11 > 0) || !(denominator > 0))
    throw degenerate("image of the absolute conic is not definite");
  const double v0 = (b12 * b13 - b11 * b23) / denominator;
  const double lambda = b33 - (b13 * b13 + v0 * (b12 * b13 - b11 * b23)) / b11;
  if (!(lambda / b11 > 0)) throw degenerate("image of the absolute conic is not definite");
  const double alpha = std::sqrt(lambda / b11);
  const double beta = std::sqrt(lambda * b11 / denominator);
  const double u0 = -b13 * alpha * alpha / lambda;  // γ = 0
  Eigen::Matrix3d kn = Eigen::Matrix3d::Identity();
  kn(0, 0) = alpha;
  kn(1, 1) = beta;
  kn(0, 2) = u0;
  kn(1, 2) = v0;
  Eigen::Matrix3d k = n.inverse() * kn;
  k /= k(2, 2);
  if (!k.allFinite() || k(0, 0) <= 0 || k(1, 1) <= 0) throw degenerate("no finite focal length");
  out.camera_matrix = k;
  return out;
}

Pose PoseFromHomography(const Eigen::Matrix3d& camera_matrix, const Eigen::Matrix3d& homography) {
  const Eigen::Matrix3d k_inverse = camera_matrix.inverse();
  const Eigen::Vector3d a1 = k_inverse * homography.col(0);
  const Eigen::Vector3d a2 = k_inverse * homography.col(1);
  const Eigen::Vector3d a3 = k_inverse * homography.col(2);
  double lambda = 2.0 / (a1.norm() + a2.norm());
  if (a3.z() * lambda < 0) lambda = -lambda;
  const Eigen::Vector3d r1 = lambda * a1;
  const Eigen::Vector3d r2 = lambda * a2;
  Eigen::Matrix3d r;
  r.col(0) = r1;
  r.col(1) = r2;
  r.col(2) = r1.cross(r2);
  return Pose::FromRotationTranslation(NearestRotation(r), lambda * a3);
}

double MaxBoardNormalAngleDeg(const std::vector<Pose>& camera_from_board) {
  double max_angle = 0;
  for (size_t i = 0; i < camera_from_board.size(); ++i) {
    const Eigen::Vector3d ni = camera_from_board[i].Rotation().col(2);
    for (size_t j = i + 1; j < camera_from_board.size(); ++j) {
      const Eigen::Vector3d nj = camera_from_board[j].Rotation().col(2);
      max_angle = std::max(max_angle, std::acos(std::clamp(ni.dot(nj), -1.0, 1.0)));
    }
  }
  return max_angle * 180.0 / M_PI;
}

}  // namespace linesight::calib
