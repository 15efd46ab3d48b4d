// The ranging chain as one object: rectify (maps computed once) -> match over the disparity range
// of the working depth range -> range user ROIs or find the obstacles automatically. Used by
// `linesight range`, `linesight eval ranging` and `linesight demo`.
#pragma once

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "linesight/geometry/depth.h"
#include "linesight/io/stereo_calibration.h"
#include "linesight/ranging/obstacle_finder.h"
#include "linesight/ranging/ranging.h"
#include "linesight/rectify/rectifier.h"
#include "linesight/stereo/matcher.h"

namespace linesight {

struct RangingPipelineOptions {
  std::string method;  // matcher name; empty = DefaultMatcherName() (isgm, else sgbm)
  std::map<std::string, std::string> params;  // matcher --param key=value settings
  int threads = 0;                            // matcher worker threads (0 = all cores)
  double min_depth_m = 0.3;  // working range: the matcher searches exactly the disparities
  double max_depth_m = 6.0;  //   of these depths (m), plus disparity_margin_px on each side
  int disparity_margin_px = 2;
  // Search from disparity 0 instead of from the far end of the working range. Costs a few
  // disparities; the background beyond max_depth_m then matches at its true disparity (and is
  // ignored by ranging) instead of being forced into a false match inside the working range.
  bool search_from_zero = false;
  bool input_rectified =
      false;  // the pair is already rectified: skip remapping, use P1 P2 Q as given
  RectifyOptions rectify;
  // Their min/max depth are overwritten by the depths of the searched disparity range (the working
  // range widened by disparity_margin_px), so that an obstacle right at max_depth_m keeps all its
  // pixels.
  RangingOptions ranging;
  ObstacleFinderOptions finder;

  void Check() const;
};

struct RangingFrame {
  cv::Mat left_rectified, right_rectified;  // 8-bit, as given (grey or BGR)
  cv::Mat disparity;  // CV_32FC1 px, +inf invalid; rows outside a band are +inf
};

class RangingPipeline {
 public:
  // Throws InputError for an unusable calibration, UsageError for an unknown method or parameter.
  RangingPipeline(const StereoCalibration& calib, const RangingPipelineOptions& options);

  // Rectifies (unless input_rectified) and matches. `rows`, if given, restricts matching to that
  // band of rectified rows (plus a margin), which is all the ranging of an ROI inside it needs.
  RangingFrame Process(const cv::Mat& left, const cv::Mat& right,
                       std::optional<cv::Range> rows = std::nullopt) const;

  std::vector<RangeResult> RangeRois(const RangingFrame& frame,
                                     const std::vector<cv::Rect>& rois) const;
  std::vector<RangeResult> RangeAuto(const RangingFrame& frame) const;

  const StereoCalibration& rectified_calibration() const { return rectified_calibration_; }
  const StereoGeometry& geometry() const { return geometry_; }
  // Disparities of the working range (DisparityRangeForDepths) and the range the matcher searches.
  const DisparityRange& disparity_range() const { return disparity_range_; }
  const DisparityRange& search_range() const { return search_range_; }
  const StereoMatcher& matcher() const { return *matcher_; }
  const std::string& method() const { return method_; }

 private:
  RangingPipelineOptions options_;
  std::optional<Rectifier> rectifier_;
  StereoCalibration rectified_calibration_;
  StereoGeometry geometry_;
  DisparityRange disparity_range_;
  DisparityRange search_range_;
  std::string method_;
  std::unique_ptr<StereoMatcher> matcher_;
};

}  // namespace linesight
