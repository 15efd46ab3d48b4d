// Distance to an obstacle inside a region of interest of a rectified disparity map, with an
// uncertainty.
//
// Definition of the reported distance: the depth Z (metres, along the rectified left optical axis)
// of the obstacle's NEAREST surface, i.e. min Z over the obstacle's visible surface -- the same
// definition the synthetic scene uses for its true distances. Estimated as f*B / (d_near + doffs),
// where d_near is a high percentile (RangingOptions::near_percentile) of the obstacle's
// median-smoothed disparities.
//
// Stages (each a function of its own in ranging_stages.h): valid disparities in the working depth
// range -> thin structures (the conductor) dropped -> log-disparity histogram -> depth modes
// separated by valleys -> the nearest mode with enough support is the obstacle (what lies behind
// it in the ROI is dropped) -> local median smoothing -> near percentile -> sigma from the
// residuals.
#pragma once

#include <limits>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "linesight/geometry/depth.h"
#include "linesight/io/stereo_calibration.h"

namespace linesight {

// Disparity search range of a matcher: [min_disparity, min_disparity + num_disparities - 1].
struct DisparityRange {
  int min_disparity = 0;
  int num_disparities = 0;
  int max_disparity() const { return min_disparity + num_disparities - 1; }
};

// The disparity range that covers depths [z_min_m, z_max_m] (plus `margin_px` on both sides, for
// subpixel interpolation and calibration error): min = floor(fB/z_max - doffs) - margin, max =
// ceil(fB/z_min - doffs)
// + margin, min clamped at 0. Throws InputError for z_min <= 0 or z_max <= z_min.
DisparityRange DisparityRangeForDepths(const StereoGeometry& geometry, double z_min_m,
                                       double z_max_m, int margin_px = 2);
DisparityRange DisparityRangeForDepths(const StereoCalibration& calib, double z_min_m,
                                       double z_max_m, int margin_px = 2);

struct RangingOptions {
  double min_depth_m = 0.2;          // disparities of nearer points are ignored (m)
  double max_depth_m = 8.0;          // disparities of farther points are ignored (m)
  int min_valid_pixels = 20;         // fewer valid pixels in the ROI -> no measurement
  double min_valid_fraction = 0.10;  // smaller share of valid pixels in the ROI -> no measurement
  // Before looking for depth modes, drop thin structures (conductors, cables): surfaces narrower
  // than this (m, at their depth) in some direction. 0 disables. Falls back to all pixels if too
  // few bodies remain.
  double min_body_width_m = 0.045;
  // ... and narrower than this many pixels (0 = off): far away, a conductor fattened by the
  // matcher's window (census 9 px wide) is wider than min_body_width_m.
  double min_body_width_px = 9.0;
  double mode_bin_relative =
      0.01;  // histogram bin width in ln(d): 0.01 = bins 1 % of the disparity wide
  // A histogram bin belongs to a depth mode while its (smoothed) count exceeds this fraction of the
  // largest bin; lower bins separate the obstacle from what lies behind (or in front of) it.
  double mode_valley_fraction = 0.08;
  double mode_min_support =
      0.10;  // share of the valid pixels a mode needs to be taken as the obstacle
  // When the thin-structure filter (min_body_width_m/px) leaves too few pixels and all are used,
  // take the mode with the most support instead of the nearest one: an ROI around an obstacle on
  // the line holds the conductor running towards the camera, nearer than the obstacle, and with
  // no body to tell them apart the nearest-mode rule takes a piece of it (eval ranging --diagnose,
  // clamp at 4 m: its 5-7 px saddle and frame bars are thin too; 2 of 8 runs took the conductor at
  // 2.8-3.0 m). false = the nearest mode, as with bodies.
  bool largest_mode_without_bodies = true;
  // Mode support is counted over the core of the ROI only: the ROI shrunk about its centre to this
  // fraction of its width and height. An occluder in front that only overlaps the ROI's margin
  // (a damper before the clamp behind it) then does not take the obstacle's place unless it
  // dominates the core. 1 = the whole ROI.
  double core_fraction = 0.6;
  // Pixels of the obstacle's depth mode within this many pixels (horizontally / vertically) of
  // the mode's silhouette are left out of the nearest-surface percentile: a matcher's window
  // (census 9x7 -> 4, 3) spreads the nearer side's disparity across a depth edge (edge
  // fattening), e.g. the conductor in front of the obstacle. Falls back to the whole mode when
  // fewer than min_valid_pixels remain. 0 disables.
  int silhouette_margin_x_px = 4;
  int silhouette_margin_y_px = 3;
  // Holes of the obstacle's mode that hold no disparity at all (pixels the matcher's checks
  // rejected) and that the mode encloses are not silhouette: with them filled, the margin leaves
  // out fewer pixels. Used when that puts the near percentile more than surface_band_relative in
  // front of the percentile without filling (a surface the holes' margins had removed), see
  // RangeObstacle.
  bool fill_rejected_holes = true;
  int smoothing_radius_px =
      2;  // median of the obstacle's disparities over (2r+1)^2 before the percentile
  // Percentile (0.5..1) of the smoothed disparities taken as the nearest surface. 0.99: with the
  // silhouette margin and the checked disparities the near tail is clean (eval ranging: 0.95 put
  // the insulator's thin shed rims 1.7 % too far, 0.99 1.1 %).
  double near_percentile = 0.99;
  // The obstacle's nearest surface as a pixel set (RangeResult::surface_pixels, what
  // RefineSurfaceDisparity matches): interior pixels whose smoothed disparity is at least
  // (1 - surface_band_relative) * d_near, i.e. within this relative depth of the nearest point.
  double surface_band_relative = 0.01;
  // Floor of the disparity uncertainty (px): matching bias that no residual reveals (subpixel
  // locking, foreshortening).
  double disparity_sigma_floor_px = 0.05;
  // Spatial correlation of matching errors: residuals of pixels closer than this (px) are not
  // independent, so the standard error uses n / correlation_length_px^2 samples.
  double correlation_length_px = 5.0;

  void Check() const;
};

enum class RangeStatus { kOk, kNoMeasurement };

struct RangeResult {
  RangeStatus status = RangeStatus::kNoMeasurement;
  std::string reason;       // why there is no measurement (empty when kOk)
  cv::Rect roi;             // the region that was searched
  cv::Rect box;             // bounding box of the obstacle's pixels (empty without a measurement)
  double distance_m = 0.0;  // nearest-surface depth (see the file comment)
  double sigma_m = 0.0;     // 1-sigma uncertainty of distance_m
  double valid_fraction = 0.0;      // share of ROI pixels with a disparity in the working range
  int obstacle_pixels = 0;          // pixels assigned to the obstacle's depth mode
  double disparity_px = 0.0;        // d_near
  double disparity_sigma_px = 0.0;  // uncertainty of d_near
  double median_distance_m = 0.0;   // depth of the obstacle mode's median disparity (its "centre")
  // The nearest surface (see RangingOptions::surface_band_relative), image coordinates, and the
  // mean of its smoothed disparities.
  std::vector<cv::Point> surface_pixels;
  double surface_disparity_px = 0.0;
  // Set by RangingPipeline when the front surface was refined on the images
  // (RefineSurfaceDisparity): the disparity from the matched map alone, before the refinement.
  bool refined = false;
  // How: "surface" (RefineSurfaceDisparity on the surface's clean pixels) or "edges"
  // (MeasureEdgeDisparity on its silhouette edges); empty when not refined.
  std::string refinement;
  double matched_disparity_px = 0.0;
  // The disagreement of the second reading that decided (Measurement::disagreement_px, see
  // measurement.h) when RangingPipeline measured the surface again, NaN otherwise: the photometric
  // surface disparity minus the matched surface mean, or with refinement "edges" the edges'
  // disparity minus the matched d_near (both the nearest point). When the result was not refined
  // it may be the end of the search window where the correlation was highest (the photometric
  // peak lies at or beyond it).
  double surface_check_px = std::numeric_limits<double>::quiet_NaN();

  bool ok() const { return status == RangeStatus::kOk; }
};

// Ranges the obstacle in `roi` of a rectified left disparity map (CV_32FC1, +inf invalid). Throws
// InputError when the ROI is empty or not inside the image, or the disparity holds NaN/-inf.
// Returns kNoMeasurement with a reason when the ROI holds too little valid disparity.
RangeResult RangeObstacle(const cv::Mat& disparity, const StereoGeometry& geometry,
                          const cv::Rect& roi, const RangingOptions& options);
RangeResult RangeObstacle(const cv::Mat& disparity, const StereoCalibration& calib,
                          const cv::Rect& roi, const RangingOptions& options);

// Throws InputError ("ROI 700,10,100,50 is not inside the 752x480 image") unless roi is non-empty
// and inside.
void CheckRoi(const cv::Rect& roi, cv::Size image_size);
// "x,y,w,h" -> cv::Rect; throws UsageError naming the text.
cv::Rect ParseRoi(const std::string& text);
// `box` grown by grow_x_px on the left and right and grow_y_px above and below, clipped to the
// image.
cv::Rect GrowRoiByPixels(const cv::Rect& box, int grow_x_px, int grow_y_px, cv::Size image_size);
// The ROI the accuracy studies range: `box` grown by `fraction` of its size plus `margin_px` on
// every side, clipped to the image.
cv::Rect GrowRoi(const cv::Rect& box, cv::Size image_size, double fraction = 0.15,
                 int margin_px = 6);

// Statistics of repeated measurements of one obstacle (the accuracy studies' cells): results[i]
// measured an obstacle at true distance truths[i].
struct RangeRunStats {
  int runs = 0, measured = 0, covered = 0;  // covered: |measured - truth| <= 2 sigma
  double mean_m = 0.0, std_m = 0.0, mean_sigma_m = 0.0, mean_abs_relative = 0.0;
  std::map<std::string, int> failures;  // reason -> runs without a measurement
};
RangeRunStats SummariseRangeRuns(const std::vector<RangeResult>& results,
                                 const std::vector<double>& truths);

nlohmann::json RangeResultToJson(const RangeResult& result);

}  // namespace linesight
