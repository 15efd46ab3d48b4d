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
//                  Σ |reprojection residual|²                                     (px², both
//                  images)
//                + w_p² Σ [ (f/D_i)² |Δ_i⊥|² + (f·B/D_i²)² (Δ_i∥)² ]              (3D point term)
//                + w_d² Σ (f₀/Z̄_ij)² (|X̂_i − X̂_j| − |P_i − P_j|)²                (adjacent-distance
//                term) where X̂_i is the midpoint triangulation of corner i from its left and right
//                pixels with the current parameters (undistorted inside the cost), Δ_i = X̂_i −
//                left_from_board·P_i its distance from the known board point, split into the part
//                across the left viewing ray (Δ⊥, scaled by f/D into a lateral image error in px)
//                and along it (Δ∥, scaled by f·B/D² into a disparity error in px); D_i =
//                |left_from_board·P_i|, f = left fx and B = |T| are the current values, so each 3D
//                residual has about the spread of one pixel residual whatever the parameters (a
//                fixed or a per-axis scale lets the optimiser shrink the apparent depth noise by
//                biasing f and B: +10 px in fx in the simulation). Defaults w_p = 0.5, w_d = 0. The
//                3D term re-uses the same pixels, so it cannot add information: reprojection alone
//                is already the maximum-likelihood estimate and reaches the Cramér-Rao bound. In
//                the simulation (σ = 0.5 px, 20 images, 200 trials) w_p = 1 makes fx/fy 14 % worse
//                than zhang, w_p = 0.5 costs 1.4 % and w_p = 0.25 nothing measurable. The distance
//                term is biased under noise (E|X̂_i − X̂_j| exceeds the true length; fx 5 % low at
//                w_d = 0.3), so it is available but off.
// opencv         cv::calibrateCamera per camera, then
// cv::stereoCalibrate(CALIB_USE_INTRINSIC_GUESS) on
//                the pair views; board poses are refined afterwards (pose only, OpenCV's parameters
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
  int min_views = 3;                // fewest views per camera and fewest pair views
  double min_normal_angle_deg = 3;  // degenerate if all board normals lie within this angle (deg)
  // Degenerate if σ5/σ1 of Zhang's constraint matrix is below this (all boards parallel: ~1e-3).
  double min_closed_form_conditioning = 5e-3;
  int max_iterations = 200;           // Levenberg-Marquardt iterations per solve
  double function_tolerance = 1e-12;  // relative cost change that stops LM
  double recon_point_weight = 0.5;    // w_p of the recon objective (see above), >= 0
  double recon_distance_weight =
      0.0;  // w_d of the recon objective, >= 0 (biased under noise, see above)

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
