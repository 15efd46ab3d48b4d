// Stereo calibration by three methods on the same detected corners.
//
// zhang  (ours)  per camera: Zhang's closed form (zhang.h), then Levenberg-Marquardt (Ceres) over
// K,
//                distortion and every board pose; right_from_left initialised from the per-view
//                poses (chordal mean of the rotations, per-axis median of the translations);
//                finally a joint Levenberg-Marquardt over both cameras, right_from_left and the
//                left board poses minimising the reprojection error of both images (the
//                maximum-likelihood estimate under i.i.d. Gaussian corner noise).
// recon  (ours)  as zhang per camera; then the board points of every pair view are expressed in
// each
//                camera frame and right_from_left is the rigid alignment of the two
//                centroid-subtracted point sets (Kabsch/Umeyama via SVD, det(R) = +1 enforced). The
//                joint refinement minimises
//                  Σ |reprojection residual|²                                   (px², both images)
//                + w_p² Σ |S_i (X̂_i − left_from_board·P_i)|²                    (3D point term)
//                + w_d² Σ (f₀/Z̄_ij)² (|X̂_i − X̂_j| − |P_i − P_j|)²              (adjacent-distance
//                term) where X̂ is the midpoint triangulation of a corner from its left and right
//                pixels with the current parameters (undistorted inside the cost), P the known
//                board point, S_i = diag(f₀/Z_i, f₀/Z_i, f₀·B₀/Z_i²) turns the 3D error into
//                pixel-equivalent units (lateral error as seen by the left camera, depth error as
//                disparity), with f₀, B₀, Z_i from the initial estimate and held fixed. Defaults
//                w_p = w_d = 1: a 3D residual counts like one more pixel observation, so the metric
//                board geometry pins the focal length against the board distance and the principal
//                point against the rotation.
// opencv         cv::calibrateCamera per camera, then
// cv::stereoCalibrate(CALIB_USE_INTRINSIC_GUESS) on the
//                pair views; board poses are refined afterwards (pose only, OpenCV's parameters
//                fixed) so that the report can evaluate every method the same way.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "linesight/calib/camera_model.h"
#include "linesight/calib/pattern.h"
#include "linesight/calib/pose.h"
#include "linesight/calib/zhang.h"

namespace linesight::calib {

enum class CalibrationMethod { kZhang, kRecon, kOpenCV };
std::string MethodName(CalibrationMethod method);
// "zhang" | "recon" | "opencv"; throws UsageError otherwise.
CalibrationMethod ParseMethod(const std::string& name);

// The corners of every pair: left[i] / right[i] are empty when that camera did not see the board.
struct StereoObservations {
  BoardGeometry board;
  cv::Size image_size;
  std::vector<ViewObservations> left, right;

  bool IsPair(size_t view) const { return !left[view].empty() && !right[view].empty(); }
  size_t size() const { return left.size(); }
};
StereoObservations ObservationsFromDetections(const StereoDetections& detections,
                                              const BoardGeometry& board);

// Which distortion coefficients are estimated (the rest are held at zero).
struct DistortionModel {
  bool rational = false;         // estimate k4 k5 k6 (OpenCV CALIB_RATIONAL_MODEL)
  bool fix_k3 = false;           // hold k3 = 0 (OpenCV CALIB_FIX_K3)
  bool zero_tangential = false;  // hold p1 = p2 = 0 (OpenCV CALIB_ZERO_TANGENT_DIST)

  // Intrinsic indices (IntrinsicIndex) held constant.
  std::vector<int> FixedIndices() const;
  // Number of OpenCV distortion coefficients to write (5 or 8).
  int OpenCVCount() const { return rational ? 8 : 5; }
  int OpenCVFlags() const;
};

struct StereoCalibrationOptions {
  CalibrationMethod method = CalibrationMethod::kZhang;
  DistortionModel distortion;
  int min_views = 3;                  // fewest views per camera and fewest pair views
  double min_normal_angle_deg = 3;    // degenerate if all board normals lie within this angle (deg)
  int max_iterations = 200;           // Levenberg-Marquardt iterations per solve
  double function_tolerance = 1e-12;  // relative cost change that stops LM
  double recon_point_weight = 1.0;    // w_p of the recon objective (see above), >= 0
  double recon_distance_weight = 1.0;  // w_d of the recon objective, >= 0

  void Check() const;
};

struct StereoCalibrationResult {
  CalibrationMethod method = CalibrationMethod::kZhang;
  DistortionModel distortion;
  CameraIntrinsics left, right;
  Pose right_from_left;
  // Per view: the board pose in the left camera (every view the left camera saw) and in the right
  // camera for views that only the right camera saw. For pair views the right pose is
  // right_from_left·left pose.
  std::vector<std::optional<Pose>> left_from_board, right_only_from_board;
  double method_reported_rms =
      -1;  // RMS reported by the method itself (OpenCV's return value), -1 if none
};

// Checks the input (enough views, non-degenerate poses) and calibrates. Throws InputError on bad
// input.
StereoCalibrationResult CalibrateStereo(const StereoObservations& observations,
                                        const StereoCalibrationOptions& options);

// Right_from_left from two point sets (rows = points, same order): R, T minimising Σ|R·a + T − b|²,
// with det(R) = +1 (Kabsch/Umeyama without scale).
Pose AlignPointSets(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b);

// Midpoint triangulation in the left camera frame of normalised undistorted left/right coordinates.
Eigen::Vector3d TriangulateMidpoint(const Eigen::Vector2d& left_normalized,
                                    const Eigen::Vector2d& right_normalized,
                                    const Pose& right_from_left);

}  // namespace linesight::calib
