// Evaluation of a stereo calibration on its own corners, identical for every method: reprojection
// RMS per view and camera, stereo RMS, epipolar error after rectification, 3D reconstruction error,
// parameter standard deviations from the Jacobian of the reprojection model; plus the outputs
// (stereo.yml content, ROS camera_info, JSON, corner-coverage image).
#pragma once

#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "linesight/calib/stereo_calibrator.h"
#include "linesight/io/stereo_calibration.h"

namespace linesight::calib {

// (JᵀJ)⁻¹ of the stereo reprojection model (pixel residuals of both images; parameters: both
// cameras' free intrinsics, right_from_left and every board pose) at the given estimate, restricted
// to the camera and stereo parameters. Fixed coefficients have zero rows/columns.
// `residual_variance` is the estimate σ̂² = Σr² / (m − n) of the pixel noise variance.
struct ReprojectionCovariance {
  bool valid = false;  // false when JᵀJ is singular
  Eigen::Matrix<double, kNumIntrinsics, kNumIntrinsics> left, right;
  Eigen::Matrix<double, kPoseSize, kPoseSize> right_from_left;
  double residual_variance = 0;
  int residual_count = 0;
  int parameter_count = 0;
};
ReprojectionCovariance ComputeReprojectionCovariance(const StereoObservations& observations,
                                                     const StereoCalibrationResult& estimate);

struct CalibrationReport {
  std::vector<double> left_view_rms_px, right_view_rms_px;  // per pair, NaN when not seen
  double left_rms_px = 0, right_rms_px = 0;                 // all views of that camera
  // OpenCV's definition: sqrt(Σ|e|² / number of residual points) over both images of the pair
  // views.
  double stereo_rms_px = 0;
  double epipolar_mean_abs_dy_px = 0;  // mean |y_left − y_right| of corners after rectification
  int epipolar_points = 0;
  double reconstruction_rmse_m = 0;   // RMSE of triangulated adjacent-corner distances − true
  double reconstruction_percent = 0;  // the same in % of the mean true distance (square size)
  int reconstruction_pairs = 0;
  std::array<double, kNumIntrinsics> left_stddev{}, right_stddev{};  // σ̂·sqrt(diag(JᵀJ)⁻¹)
  std::array<double, kPoseSize> right_from_left_stddev{};            // rad (angle-axis), m
  bool stddev_valid = false;
  StereoCalibration calibration;  // with E, F and the rectification (R1 R2 P1 P2 Q) filled
};

// Fills a StereoCalibration from the estimate, rectified with cv::stereoRectify
// (CALIB_ZERO_DISPARITY, alpha = 0).
StereoCalibration MakeStereoCalibration(const StereoCalibrationResult& estimate,
                                        cv::Size image_size);

// Stereo RMS only (cheap; used by the simulation study).
double StereoRms(const StereoObservations& observations, const StereoCalibrationResult& estimate);

CalibrationReport EvaluateCalibration(const StereoObservations& observations,
                                      const StereoCalibrationResult& estimate);

// ROS camera_info YAML (camera_calibration_parsers layout) for one camera of the rectified pair.
std::string RosCameraInfoYaml(const std::string& camera_name, cv::Size image_size,
                              const cv::Mat& camera_matrix, const cv::Mat& distortion,
                              const cv::Mat& rectification, const cv::Mat& projection);

// The JSON report of `linesight calibrate`.
nlohmann::json ReportToJson(const StereoDetections& detections,
                            const StereoCalibrationResult& estimate,
                            const CalibrationReport& report);

// Every detected corner of the left (left half) and right (right half) images drawn on one canvas,
// one colour per view, with the board outline: shows which parts of the image the calibration
// constrains.
cv::Mat CoverageImage(const StereoObservations& observations);

// Bar chart (SVG) of the per-view RMS of both cameras.
std::string PerViewRmsSvg(const CalibrationReport& report);

}  // namespace linesight::calib
