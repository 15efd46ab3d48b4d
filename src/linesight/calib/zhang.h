// Zhang's closed-form initialisation ("A flexible new technique for camera calibration", PAMI
// 2000): board-to-image homographies by the normalised DLT, intrinsics from the image of the
// absolute conic B = K^-T K^-1 (with the zero-skew constraint B12 = 0 added), and per-view
// extrinsics from K^-1 H.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "linesight/calib/camera_model.h"
#include "linesight/calib/pose.h"

namespace linesight::calib {

// A camera's view of the board: ids index BoardGeometry::points; empty when the board was not seen.
struct ViewObservations {
  std::vector<int> ids;
  std::vector<Eigen::Vector2d> pixels;
  bool empty() const { return ids.empty(); }
};

// Homography H with pixel ~ H·(X, Y, 1) for board points on z = 0, by the DLT on Hartley-normalised
// coordinates (centroid at 0, mean distance √2). Needs >= 4 points in general position.
Eigen::Matrix3d EstimateHomography(const std::vector<Eigen::Vector2d>& board_xy,
                                   const std::vector<Eigen::Vector2d>& pixels);

// Result of the closed form over several homographies.
struct ClosedFormIntrinsics {
  Eigen::Matrix3d camera_matrix = Eigen::Matrix3d::Identity();
  // σ5/σ1 of the (row-normalised) constraint matrix V: near zero when the views cannot determine K
  // (e.g. all boards parallel).
  double conditioning = 0;
};

// Closed-form K from >= 2 homographies (zero skew imposed). Throws InputError (message starting
// with `camera_name`) when the conditioning is below `min_conditioning` (all boards parallel gives
// ~1e-3 at 0.1-0.5 px noise, well-spread tilts ~0.05-0.1) or B is not positive definite.
ClosedFormIntrinsics IntrinsicsFromHomographies(const std::vector<Eigen::Matrix3d>& homographies,
                                                cv::Size image_size, const std::string& camera_name,
                                                double min_conditioning = 5e-3);

// camera_from_board from K and H (r1 = λK⁻¹h1, r2 = λK⁻¹h2, r3 = r1×r2, t = λK⁻¹h3, R projected
// onto SO(3); sign chosen so that the board lies in front of the camera).
Pose PoseFromHomography(const Eigen::Matrix3d& camera_matrix, const Eigen::Matrix3d& homography);

// Largest angle (degrees) between the board normals of the given poses.
double MaxBoardNormalAngleDeg(const std::vector<Pose>& camera_from_board);

}  // namespace linesight::calib
