// Depth from disparity for a rectified pair: Z = f*B / (d + doffs), and 3D points through Q.
// Depth maps are CV_32FC1 in metres with 0 meaning "no depth".
#pragma once

#include <filesystem>
#include <string>

#include <opencv2/core.hpp>

#include "linesight/io/stereo_calibration.h"

namespace linesight {

inline constexpr float kNoDepth = 0.0f;

// The rectified pinhole pair in the terms depth needs. Z = focal_px * baseline_m / (d +
// disparity_offset_px).
struct StereoGeometry {
  double focal_px = 0.0;             // rectified focal length (px)
  double baseline_m = 0.0;           // distance between the optical centres (m)
  double disparity_offset_px = 0.0;  // cx_right - cx_left (px); 0 with CALIB_ZERO_DISPARITY
  double cx = 0.0, cy = 0.0;         // rectified principal point of the left view (px)

  double DepthFromDisparity(double disparity_px) const {
    return focal_px * baseline_m / (disparity_px + disparity_offset_px);
  }
  double DisparityFromDepth(double depth_m) const {
    return focal_px * baseline_m / depth_m - disparity_offset_px;
  }
  // Depth uncertainty from a disparity uncertainty: sigma_Z = Z^2 * sigma_d / (f * B).
  double DepthSigma(double depth_m, double disparity_sigma_px) const {
    return depth_m * depth_m * disparity_sigma_px / (focal_px * baseline_m);
  }
};

// Reads f, B, doffs and the principal point from Q (as cv::stereoRectify writes it):
// f = Q(2,3), 1/B = Q(3,2), doffs = Q(3,3)/Q(3,2), cx = -Q(0,3), cy = -Q(1,3).
// Throws InputError if Q is missing or does not describe a horizontal rig with f > 0 and B > 0.
StereoGeometry GeometryFromCalibration(const StereoCalibration& calib);

// Throws InputError naming `name` and the first offending pixel unless the map is CV_32FC1 holding
// finite values or +inf ("no estimate"): NaN and -inf are rejected.
void CheckDisparityMap(const cv::Mat& disparity, const std::string& name);

// Depth (m, CV_32FC1) of every pixel; kNoDepth where the disparity is invalid or d + doffs <= 0.
cv::Mat DepthFromDisparity(const cv::Mat& disparity, const StereoGeometry& geometry);

// 3D points (CV_32FC3, metres, left rectified camera frame): [X Y Z W]^T = Q [x y d 1]^T. Pixels
// without a valid disparity or with W <= 0 get NaN.
cv::Mat PointsFromDisparity(const cv::Mat& disparity, const cv::Mat& Q);

// 16-bit PNG depth in millimetres (value = round(Z * 1000), 0 = no depth; depths beyond 65.535 m
// are written as 0). Written atomically.
inline constexpr double kDepthPngUnitsPerMetre = 1000.0;
void WriteDepthPng16(const std::filesystem::path& path, const cv::Mat& depth_m);
// Reads a 16-bit depth PNG back to metres (CV_32FC1, kNoDepth where the value is 0).
cv::Mat ReadDepthPng16(const std::filesystem::path& path);

}  // namespace linesight
