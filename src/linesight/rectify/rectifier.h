// Bouguet stereo rectification (OpenCV stereoRectify + initUndistortRectifyMap + remap). The remap
// tables are computed once per calibration and reused for every frame.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "linesight/io/stereo_calibration.h"

namespace linesight {

struct RectifyOptions {
  // Recompute R1 R2 P1 P2 Q with cv::stereoRectify from M1 D1 M2 D2 R T (true), or use the ones
  // stored in the calibration file as the calibrate command wrote them (false). Stored matrices
  // that are missing are always recomputed.
  bool recompute = false;
  // Free scaling of cv::stereoRectify, used only when recomputing: 0 keeps only valid pixels
  // (zoomed in), 1 keeps every source pixel (black borders), -1 lets OpenCV choose.
  double alpha = 0.0;
  // Make the principal points of both rectified views equal (cv::CALIB_ZERO_DISPARITY), so that
  // Z = f*B/d with no disparity offset. Used only when recomputing.
  bool zero_disparity = true;
  // Interpolation used by remap: cv::INTER_LINEAR or cv::INTER_CUBIC.
  int interpolation = 1;  // cv::INTER_LINEAR

  void Check() const;
};

// The rectified geometry: the calibration with R1 R2 P1 P2 Q describing the rectified views, plus
// the rectangles of valid (fully defined) pixels in each rectified view.
struct Rectification {
  StereoCalibration calibration;
  cv::Rect valid_roi_left;
  cv::Rect valid_roi_right;
  // Intersection of both valid rectangles.
  cv::Rect CommonValidRoi() const { return valid_roi_left & valid_roi_right; }
};

// Runs cv::stereoRectify on the intrinsics/extrinsics of `calib` (its R1..Q are ignored and
// replaced). Throws InputError when the calibration is incomplete.
Rectification ComputeRectification(const StereoCalibration& calib, const RectifyOptions& options);

class Rectifier {
 public:
  // Builds the remap tables for `calib` (an image of calib.image_size per view).
  Rectifier(const StereoCalibration& calib, const RectifyOptions& options = {});

  // Rectifies one pair. Throws InputError unless both images have the calibrated size.
  void Rectify(const cv::Mat& left, const cv::Mat& right, cv::Mat* left_rectified,
               cv::Mat* right_rectified) const;
  cv::Mat RectifyLeft(const cv::Mat& left) const;
  cv::Mat RectifyRight(const cv::Mat& right) const;

  // Maps raw (distorted) pixel positions to rectified ones.
  std::vector<cv::Point2f> RectifyLeftPoints(const std::vector<cv::Point2f>& raw) const;
  std::vector<cv::Point2f> RectifyRightPoints(const std::vector<cv::Point2f>& raw) const;

  // Calibration of the rectified pair (P1, P2, Q describe the rectified views).
  const StereoCalibration& calibration() const { return rectification_.calibration; }
  const Rectification& rectification() const { return rectification_; }
  // The remap tables (CV_32FC1 each): raw position of every rectified pixel.
  const cv::Mat& left_map_x() const { return left_map_x_; }
  const cv::Mat& left_map_y() const { return left_map_y_; }

 private:
  cv::Mat Remap(const cv::Mat& image, const cv::Mat& map_x, const cv::Mat& map_y,
                const char* which) const;

  RectifyOptions options_;
  Rectification rectification_;
  cv::Mat left_map_x_, left_map_y_, right_map_x_, right_map_y_;
};

// Side-by-side image of a rectified pair with horizontal lines every `spacing` rows, to check by
// eye that corresponding points lie on the same row. Grey inputs are converted to BGR.
cv::Mat DrawEpipolarCheck(const cv::Mat& left_rectified, const cv::Mat& right_rectified,
                          int spacing = 32);

}  // namespace linesight
