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
//                each camera frame and right_from_left is the rigid alignment of the two
//                centroid-subtracted point sets (Kabsch/Umeyama via SVD, det(R) = +1 enforced).
//                The joint refinement expresses every corner seen by both cameras through its 3D
//                reconstruction X̂ (midpoint triangulation of its two observed pixels with the
//                current parameters) and minimises
//                  Σ_corners in one image only |e|²
//                + Σ_corners in both images [ eᵀ(I − w_p²·P)e + w_p²·ΔᵀC⁻¹Δ ]
//                + w_d² Σ (f₀/Z̄_ij)² (|X̂_i − X̂_j| − |P_i − P_j|)²   (adjacent distances, off)
//                e: the corner's reprojection residuals (px; 4 for a corner in both images);
//                Δ = X̂ − left_from_board·P its 3D reconstruction error (m); C = A·Aᵀ with
//                A = ∂X̂/∂pixels, so σ²·C is the covariance of Δ under i.i.d. pixel noise σ and
//                ΔᵀC⁻¹Δ is the reconstruction error in the units of the reprojection χ² (px², σ
//                cancels); P = Aᵀ C⁻¹ A projects pixel space onto the 3 directions the
//                triangulation sees (the remaining one is the epipolar residual).
//                Why these weights: to first order Δ = −A·e, so ΔᵀC⁻¹Δ = eᵀP·e and each corner
//                term equals |e|²: the objective is the reprojection χ² (the likelihood under
//                Gaussian noise) with the share w_p² of each corner's information taken in metric
//                3D form instead of pixels, never counted twice, so recon keeps the efficiency of
//                the maximum-likelihood estimate (and the Ceres covariance stays valid). Rejected
//                alternatives, measured in the simulation (σ = 0.5 px, 20 images): an additive 3D
//                term Σ|e|² + w²·Σ(scaled Δ)² weights the same pixels (1 + w²) times in three
//                directions and once in the fourth, a weighted least squares with the wrong
//                weight matrix: fx/fy +1.4 % (seed 42) to +6 % (seed 7) over zhang at w = 0.5,
//                +14 % at w = 1; and C, P frozen at a starting estimate let the optimiser shrink
//                the apparent depth noise A·e by moving fx and the board distances along their
//                weakly determined direction: fx −0.3 % to −1.9 % per trial at w_p = 1. Here A,
//                C and P are evaluated at the current parameters inside the cost (A by central
//                differences in the fixed pixels, exact derivatives in the parameters). Default
//                w_p = 1: the stereo information of a corner is carried entirely by its 3D
//                reconstruction error plus its epipolar residual (1 dof).
//                The distance term is an additive, non-likelihood term and biased under noise
//                (E|X̂_i − X̂_j| exceeds the true length; fx 5 % low at w_d = 0.3): available, off.
//                Optional board-shape model (recon_board_bend, off): every recon term sees the
//                board points bent along the board normal by a shared quadratic
//                b0·u² + b1·v² + b2·u·v (BendBoard; 3 parameters for all views) estimated with the
//                rest; a printed board is not flat. The report then evaluates on the bent board.
//                Corner-noise model (recon_noise, default kView): the whitening above assumes one
//                pixel noise σ for every corner; real views differ (blur, distance, lighting:
//                opencv-doc's per-view RMS spans 0.17 … 0.31 px). recon first solves with i.i.d.
//                weights, then estimates a relative noise level per camera and view from the
//                residuals (EstimateReconNoiseScales, shrunk toward the pooled level so that
//                sampling scatter alone gives no weights), and solves again (2 rounds) with each
//                camera's residuals and pixel covariance in the A·Σ·Aᵀ of its corners scaled
//                by that level: the likelihood under heteroscedastic Gaussian noise. kIid is the
//                previous objective; kCamera one level per camera.
// opencv         cv::calibrateCamera per camera, then
// cv::stereoCalibrate(CALIB_USE_INTRINSIC_GUESS) on
//                the pair views; board poses are refined afterwards (pose only, OpenCV's parameters
//                fixed) so that the report can evaluate every method the same way.
#pragma once

#include <array>
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

// recon's corner-noise model: i.i.d. over all corners, one level per camera, or one per camera
// and view (levels estimated from the residuals, see recon_noise in StereoCalibrationOptions).
enum class ReconNoiseModel { kIid, kCamera, kView };
std::string ReconNoiseName(ReconNoiseModel model);
// "iid" | "camera" | "view"; throws UsageError otherwise.
ReconNoiseModel ParseReconNoise(const std::string& name);
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
  // w_p of the recon objective (see above): share w_p² of each stereo corner's information taken
  // through its whitened 3D reconstruction error, in [0, 1] (0 = zhang's objective).
  double recon_point_weight = 1.0;
  double recon_distance_weight =
      0.0;  // w_d of the recon objective, >= 0 (biased under noise, see above)
  // recon: estimate the board's shared quadratic bend (BoardBend) instead of assuming it flat.
  bool recon_board_bend = false;
  // recon: the pixel-noise model behind the whitening (kIid: every corner the same noise).
  ReconNoiseModel recon_noise = ReconNoiseModel::kView;

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
  // The board's bend (m; BendBoard): estimated by recon with recon_board_bend, else zero.
  BoardBend board_bend{};
  double method_reported_rms =
      -1;  // RMS reported by the method itself (OpenCV's return value), -1 if none
};

// Checks the input (enough views, non-degenerate poses) and calibrates. Throws InputError on bad
// input.
StereoCalibrationResult CalibrateStereo(const StereoObservations& observations,
                                        const StereoCalibrationOptions& options);

// recon's relative pixel-noise scales (left, right) per view under a noise model, from the
// reprojection residuals of an estimate (on its bent board): s² = Σ|e|² / (2n − d) per group (one
// group per camera for kCamera, per camera and view for kView; d: the group's share of the pose
// degrees of freedom, 3 per camera of a pair view, 6 for a single-camera view), shrunk toward the
// pooled level by empirical Bayes and divided by it: s² scatters around the group's true variance
// with variance 2σ⁴/dof (χ²), so only the spread beyond that, τ², is real heteroscedasticity and a
// group keeps the share τ²/(τ² + 2σ̂⁴/dof) of its deviation. With i.i.d. noise τ² ≈ 0 and every
// scale stays ≈ 1; kIid (or no residual) gives exactly 1. Views without an estimate get 1.
std::vector<std::array<double, 2>> EstimateReconNoiseScales(const StereoObservations& obs,
                                                            const StereoCalibrationResult& est,
                                                            ReconNoiseModel model);

// Right_from_left from two point sets (rows = points, same order): R, T minimising Σ|R·a + T − b|²,
// with det(R) = +1 (Kabsch/Umeyama without scale).
Pose AlignPointSets(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b);

// Midpoint triangulation in the left camera frame of normalised undistorted left/right coordinates.
Eigen::Vector3d TriangulateMidpoint(const Eigen::Vector2d& left_normalized,
                                    const Eigen::Vector2d& right_normalized,
                                    const Pose& right_from_left);

}  // namespace linesight::calib
