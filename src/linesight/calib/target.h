// Calibration targets rendered for an LCD panel: a panel is flat to well under 0.1 mm and its pixel
// pitch is known exactly, so a pattern drawn with an integer number of panel pixels per square has
// an exact size in metres (unlike a printed board).
#pragma once

#include <string>

#include <opencv2/core.hpp>

#include "linesight/calib/pattern.h"

namespace linesight::calib {

struct TargetOptions {
  PatternType type = PatternType::kChessboard;
  int cols = 9;  // inner corners (chessboard), circles per row (circles), squares per row (charuco)
  int rows = 6;  // inner corners / circles per column / squares per column
  cv::Size screen{1920, 1080};  // panel resolution (px)
  double pixel_pitch_m = 0;  // panel pixel pitch (m), e.g. 0.000248 for a 24" 1920x1080 panel; > 0
  int square_px = 0;         // square side or circle spacing in panel pixels; 0 = largest that fits
  int margin_px = 0;         // white quiet zone around the pattern (px); 0 = one square
  std::string dictionary = "4x4_50";  // ChArUco dictionary
  double marker_fraction = 0.7;       // ChArUco marker side / square side, in (0, 1)

  void Check() const;
};

struct RenderedTarget {
  cv::Mat image;        // 8-bit grey, exactly `screen` pixels, to be shown 1:1 (no scaling)
  int square_px = 0;    // square side / circle spacing (panel px)
  double square_m = 0;  // = square_px · pixel_pitch_m
  double marker_m = 0;  // ChArUco marker side (m)
  cv::Point2d
      origin_px;  // image position of the board origin (x, y) = (0, 0) (pixel-centre convention)
  std::string pattern_spec;  // what to pass to `linesight calibrate --pattern`
};

// Throws OptionError when the pattern does not fit the screen.
RenderedTarget RenderTarget(const TargetOptions& options);

}  // namespace linesight::calib
