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
#include "linesight/ranging/measurement.h"
#include "linesight/ranging/obstacle_finder.h"
#include "linesight/ranging/ranging.h"
#include "linesight/ranging/surface_refinement.h"
#include "linesight/rectify/rectifier.h"
#include "linesight/stereo/matcher.h"

namespace linesight {

// The matcher settings the ranging chain runs `method` with: `params` as given, and for isgm 8
// aggregation paths unless `params` sets "paths" (isgm's default is 4, tuned for speed on the
// dense benchmarks; on small obstacle fronts 8 are better: `eval ranging --runs 4`, 0.5-5 m, cells
// off by more than 1 %: 3 with 8 paths, 6 with 4 paths, estimated calibration). `method` empty =
// DefaultMatcherName().
std::map<std::string, std::string> RangingMatcherParams(const std::string& method,
                                                        std::map<std::string, std::string> params);

struct RangingPipelineOptions {
  std::string method;  // matcher name; empty = DefaultMatcherName() (isgm, else sgbm)
  // Matcher --param key=value settings (the chain adds RangingMatcherParams' defaults).
  std::map<std::string, std::string> params;
  int threads = 0;           // matcher worker threads (0 = all cores)
  double min_depth_m = 0.3;  // working range: the matcher searches exactly the disparities
  double max_depth_m = 6.0;  //   of these depths (m), plus disparity_margin_px on each side
  int disparity_margin_px = 2;
  // Search from disparity 0 instead of from the far end of the working range. Costs a few
  // disparities (0.3-6 m with the MYNT rig: 301 instead of 288); the background beyond max_depth_m
  // then matches at its true disparity (and is ignored by ranging) instead of being forced into a
  // false match inside the working range, which otherwise outvotes a near obstacle whose pixels
  // are partly unmatched (`linesight eval ranging`: 0.5 m read +700..+1000 % without it).
  bool search_from_zero = true;
  bool input_rectified =
      false;  // the pair is already rectified: skip remapping, use P1 P2 Q as given
  // Range on the disparities that passed the matcher's consistency checks (uniqueness, left-right,
  // speckle) only. For isgm that is its SGM stage: the plane-filled pixels of its dense output are
  // guesses (sky, terrain and unmatched image borders take a plane's value) that bias the nearest
  // surface and merge the automatic regions. Other matchers already mark such pixels invalid.
  bool range_on_checked_disparity = true;
  // Relative depth uncertainty that no residual inside the ROI reveals, added in quadrature to
  // every result's sigma_m: the calibration's error in f*B and the matcher's systematic bias at an
  // obstacle's nearest surface (subpixel locking, foreshortened thin rims). Chosen so that the
  // +-2 sigma coverage of `linesight eval ranging` reaches 90 %.
  double model_relative_sigma = 0.006;
  // Measure each result's nearest surface a second time on the rectified images and fuse the
  // readings with the matched map's (MeasureNearestSurface, FuseNearestSurface in measurement.h):
  // the surface fit on the surface's clean pixels (RefineSurfaceDisparity), where it cannot correct
  // the silhouette edges (MeasureEdgeDisparity) and the fit on every surface pixel as a check.
  // Why: the matcher flattens small fronts (the insulator's rims at 1-2.5 m read 0.5 px too far,
  // the damper's textureless end cap from 3.5 m on 0.3-0.5 px; `eval ranging --runs 4`, 0.5-5 m,
  // estimated calibration: 3 cells off by more than 1 % with the matched map alone, 1 with the fit,
  // damper 4.5 m +1.50 -> +0.16 % with the edges), and the matched map's near percentile reads flat
  // faces at 5 m 1-1.4 % too near (`eval plates`: 82 -> 90 of 90 cells within 1 %). false = the
  // matched map's reading alone.
  bool refine_on_images = true;
  // w of the fusion rule: the readings' disagreement joins sigma_d with this weight. In [0, 4].
  double surface_disagreement_weight = 1.0;
  SurfaceRefinementOptions surface;
  EdgeDisparityOptions edges;
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
  // CV_32FC1 px: the matcher's MatchResult::checked, the pixels that passed its consistency checks
  // (isgm: its SGM stage before plane filling), +inf elsewhere. The same Mat as `disparity` for the
  // other matchers.
  cv::Mat checked_disparity;
  double rectify_ms = 0;  // wall-clock time Process spent rectifying
  double match_ms = 0;    // and matching
  // What ranging uses: checked_disparity if RangingPipelineOptions::range_on_checked_disparity.
  const cv::Mat& ranging_disparity(bool checked) const {
    return checked ? checked_disparity : disparity;
  }
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
  // Adds model_relative_sigma to a RangeObstacle result (RangeRois and RangeAuto do it already).
  void AddModelUncertainty(RangeResult* result) const;
  // The second readings of an ok result's nearest surface on the frame's images, in the fusion
  // rule's order of precedence (measurement.h): the surface fit as an estimate if it can correct;
  // else the silhouette edges as a lower bound and the fit (on every surface pixel when the clean
  // ones did not suffice) as a check.
  std::vector<Measurement> MeasureNearestSurface(const RangingFrame& frame,
                                                 const RangeResult& result) const;
  // Fuses them into an ok result (FuseNearestSurface; RangeRois and RangeAuto do it already):
  // distance, sigma, refined, refinement and surface_check_px.
  void RefineSurface(const RangingFrame& frame, RangeResult* result) const;

  const StereoCalibration& rectified_calibration() const { return rectified_calibration_; }
  const StereoGeometry& geometry() const { return geometry_; }
  // Disparities of the working range (DisparityRangeForDepths) and the range the matcher searches.
  const DisparityRange& disparity_range() const { return disparity_range_; }
  const DisparityRange& search_range() const { return search_range_; }
  const StereoMatcher& matcher() const { return *matcher_; }
  const std::string& method() const { return method_; }
  const RangingPipelineOptions& options() const { return options_; }
  // The map RangeRois / RangeAuto use (see RangingPipelineOptions::range_on_checked_disparity).
  const cv::Mat& RangingDisparity(const RangingFrame& frame) const {
    return frame.ranging_disparity(options_.range_on_checked_disparity);
  }

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
