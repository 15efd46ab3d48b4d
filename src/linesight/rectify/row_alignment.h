// Calibration health from the images themselves: how far apart, vertically, the same scene point
// lies in the rectified left and right images. A good rectification puts every match on one row;
// a rig whose cameras have moved since calibration (a knock, heat) shows a growing row offset, and
// SGM-type matchers, which search along rows only, lose accuracy past about half a pixel. The
// measure is sparse and cheap (ORB corners matched both ways, ~5 ms on a 752x480 pair), so a live
// loop can take it every few seconds and show its trend.
#pragma once

#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

namespace linesight {

struct RowAlignmentOptions {
  int max_features = 1000;         // ORB corners detected per image (>= 50)
  double max_row_offset_px = 8.0;  // matches farther apart vertically are mismatches (> 0 px)
  int min_matches = 30;            // fewer consistent matches than this: no verdict (>= 5)
  // Verdict thresholds on the median |row offset|: below `good_px` the rectification is sound;
  // up to `recalibrate_px` matching degrades slightly; beyond, the rig needs recalibration
  // (0 < good_px < recalibrate_px).
  double good_px = 0.5;
  double recalibrate_px = 1.0;

  void Check() const;
};

struct RowAlignment {
  enum class Verdict { kNoVerdict, kGood, kCheck, kRecalibrate };
  Verdict verdict = Verdict::kNoVerdict;
  std::string reason;               // why there is no verdict (too little texture, ...)
  int matches = 0;                  // consistent left-right matches used
  double median_abs_offset_px = 0;  // median |y_right - y_left|
  double median_offset_px = 0;      // signed median: a rotation about the baseline shifts all
  double p90_abs_offset_px = 0;     // 90th percentile of |y_right - y_left|

  nlohmann::json ToJson() const;
};

std::string VerdictName(RowAlignment::Verdict verdict);  // "none", "good", "check", "recalibrate"

// Matches ORB corners between the two rectified images (mutual best matches, in front of the
// camera: x_left >= x_right) and measures their row offsets. Either image may be grey or BGR.
RowAlignment MeasureRowAlignment(const cv::Mat& left_rectified, const cv::Mat& right_rectified,
                                 const RowAlignmentOptions& options = {});

}  // namespace linesight
