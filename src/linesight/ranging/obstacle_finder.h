// Automatic obstacle finding (`linesight range --auto`): regions of a rectified disparity map that
// stand out of the conductor and the background. Within the working depth range a power line shows
// only conductors (a few centimetres thick) and what sits on them, so an obstacle is a connected
// region that is thicker, at its own depth, than `min_width_m`: the conductor is thinner and the
// background lies beyond the range.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "linesight/geometry/depth.h"
#include "linesight/ranging/ranging.h"

namespace linesight {

struct ObstacleFinderOptions {
  double min_depth_m = 0.2;  // working range: nearer disparities are ignored (m)
  double max_depth_m = 6.5;  // working range: farther disparities are ignored (m)
  // Parts narrower than this (metres, measured at their own depth in every direction) are not
  // obstacles; chosen above a conductor's diameter (~27 mm) and below a damper weight's (~60 mm).
  double min_width_m = 0.045;
  double depth_band_relative =
      0.04;              // pixels within ~1.5 bands of each other in ln(d) count as one surface
  int min_area_px = 40;  // smaller regions are dropped (px)
  // Regions whose boxes overlap by more than this share of the smaller box are merged ...
  double merge_overlap = 0.5;
  // ... unless their median depths differ by more than this (ln of the depth ratio): then they
  // are different obstacles, one in front of the other (the clamp at 3 m before the insulator
  // string at 4.5 m in `linesight demo`), not parts of one (a damper's weights seen end-on lie
  // 0.4 m apart, ln(1.9 / 1.5) = 0.24 at 1.5 m).
  double merge_depth_log_ratio = 0.3;

  void Check() const;
};

// Boxes (rectified left pixels) of the regions found, unordered.
std::vector<cv::Rect> FindObstacleRegions(const cv::Mat& disparity, const StereoGeometry& geometry,
                                          const ObstacleFinderOptions& options);

// Finds the obstacles and ranges each one; results with a measurement come first, sorted by
// distance.
std::vector<RangeResult> RangeAllObstacles(const cv::Mat& disparity, const StereoGeometry& geometry,
                                           const ObstacleFinderOptions& finder_options,
                                           const RangingOptions& ranging_options);

}  // namespace linesight
