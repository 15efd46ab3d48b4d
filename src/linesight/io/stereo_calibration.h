// Stereo calibration in OpenCV FileStorage YAML, as OpenCV's own stereo sample writes it:
// image_width, image_height, M1 D1 M2 D2 R T E F R1 R2 P1 P2 Q. T in metres.
// R, T are right_from_left: X_right = R * X_left + T.
#pragma once

#include <filesystem>
#include <string>

#include <opencv2/core.hpp>

namespace linesight {

struct StereoCalibration {
  cv::Size image_size;  // width x height in pixels
  cv::Mat M1, D1;  // left camera matrix (3x3 CV_64F) and distortion (1xN CV_64F, plumb_bob order)
  cv::Mat M2, D2;  // right camera
  cv::Mat R, T;    // right_from_left rotation (3x3) and translation (3x1, metres)
  cv::Mat E, F;    // essential and fundamental matrices
  cv::Mat R1, R2;  // rectifying rotations
  cv::Mat P1, P2;  // rectified projections (3x4)
  cv::Mat Q;       // disparity-to-depth (4x4)

  // Rectified focal length (px) and baseline (m) from P1/P2: B = -P2(0,3) / P2(0,0).
  double RectifiedFocal() const;
  double Baseline() const;
};

// Throws InputError naming the file and the missing/malformed field ("stereo.yml: field 'Q' is
// missing", "stereo.yml: field 'M1' must be a 3x3 matrix, got 3x2").
StereoCalibration ReadStereoCalibration(const std::filesystem::path& path);
// Writes atomically, always in YAML (whatever the extension), as EncodeStereoCalibration returns
// it.
void WriteStereoCalibration(const std::filesystem::path& path, const StereoCalibration& calib);

// Parses FileStorage text already in memory (used by ReadStereoCalibration and by the fuzzer);
// `name` is used in messages. Matrices may be stored as float or double; they are returned as
// CV_64F. T may be 3x1 or 1x3 and is returned as 3x1; D1/D2 hold 4, 5, 8, 12 or 14 coefficients and
// are returned as 1xN.
StereoCalibration DecodeStereoCalibration(const std::string& text, const std::string& name);
// The YAML text ("%YAML:1.0", image_width, image_height, then the matrices as !!opencv-matrix).
std::string EncodeStereoCalibration(const StereoCalibration& calib);

// The calibration of an already rectified pinhole pair: identical cameras with focal length f
// (px), the left principal point (cx, cy), the right camera `baseline_m` to the right and its
// principal point `doffs_px` further right (Middlebury's doffs: Z = B f / (d + doffs)), no
// distortion, identity rectification. Throws InputError unless f > 0, baseline_m > 0 and every
// value is finite.
StereoCalibration RectifiedPinholeCalibration(cv::Size image_size, double focal_px, double cx,
                                              double cy, double baseline_m, double doffs_px = 0.0);

// Checks that the calibration matches an image size; throws InputError otherwise.
void CheckCalibrationMatchesImage(const StereoCalibration& calib, cv::Size image_size,
                                  const std::filesystem::path& calib_path);

}  // namespace linesight
