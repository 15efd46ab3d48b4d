// The stages of RangeObstacle (ranging.h), each a function of its own with a typed result:
//   SelectWorkingPixels (valid disparities of the working depth range)
//   -> KeepBodies (thin structures such as the conductor dropped)
//   -> FindObstacleMode (log-disparity histogram, depth modes separated by valleys, the nearest
//      mode with enough support in the ROI's core)
//   -> ObstacleMask (the mode's pixels, pieces reaching the core)
//   -> SmoothObstacle (local medians over the obstacle's own pixels, residuals against a wider one)
//   -> NearestSurface (near percentile of the smoothed interior, rejected holes filled)
//   -> NearSurfaceSigma (uncertainty of the nearest-surface disparity).
// Images and masks are over the ROI; every mask is CV_8U with 1 (or any non-zero) = member.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/core.hpp>

#include "linesight/geometry/depth.h"
#include "linesight/ranging/ranging.h"

namespace linesight::detail {

// Linearly interpolated quantile p in [0, 1] of `values` (not empty).
double Quantile(std::vector<float> values, double p);
// The same, reordering `values` in place instead of copying them.
double QuantileInPlace(std::vector<float>* values, double p);
double Median(std::vector<float> values);

struct WorkingPixels {
  cv::Mat valid;              // ROI mask of the usable pixels
  std::vector<float> values;  // their disparities, row-major
  double d_low = 0.0;         // disparity of max_depth_m
  double d_high = 0.0;        // disparity of min_depth_m
};
// Pixels of `view` (the ROI of the disparity map) with a finite disparity of a depth inside
// [min_depth_m, max_depth_m] (and a positive d + doffs).
WorkingPixels SelectWorkingPixels(const cv::Mat& view, const StereoGeometry& geometry,
                                  const RangingOptions& options);

// Drops the pixels of thin structures (RangingOptions::min_body_width_m / _px) from `pixels`.
// Returns false, keeping every pixel, when fewer than min_valid_pixels bodies remain (or the
// filter is off and nothing needs dropping: then true).
bool KeepBodies(const cv::Mat& disparity, const StereoGeometry& geometry, const cv::Rect& roi,
                const RangingOptions& options, WorkingPixels* pixels);

// Bins of equal relative depth width: ln(d + doffs) in steps of mode_bin_relative, with one empty
// guard bin at each end (bins 1..count are the data's).
struct LogDisparityBins {
  double offset = 0.0, log_low = 0.0, width = 0.01;
  int count = 1;
  int Bin(double d) const {
    return 1 + std::clamp(int((std::log(d + offset) - log_low) / width), 0, count - 1);
  }
};

struct DepthMode {
  bool found = false;
  int first = 0, last = 0;  // bins of the obstacle's mode (grown by one on each side)
  LogDisparityBins bins;
  cv::Rect core;          // the ROI's core (RangingOptions::core_fraction), ROI coordinates
  bool use_core = false;  // support was counted in the core (it held min_valid_pixels)
  int support_pixels = 0;
};
// The obstacle's depth mode among `pixels`: the nearest run of histogram bins above the valley
// level holding mode_min_support of the support pixels; with `only_thin` (no body left) and
// largest_mode_without_bodies, the run with the most support instead.
DepthMode FindObstacleMode(const cv::Mat& view, const WorkingPixels& pixels, double offset,
                           bool only_thin, const RangingOptions& options);

// The mode's pixels; where the core is used, only the connected pieces that reach into it (all
// pieces if none does).
cv::Mat ObstacleMask(const cv::Mat& view, const WorkingPixels& pixels, const DepthMode& mode);

struct SmoothedObstacle {
  std::vector<cv::Point> points;  // ROI coordinates of the obstacle's pixels, row-major
  std::vector<float> raw;         // their disparities
  std::vector<float> smoothed;    // median over (2r+1)^2 of the obstacle's pixels (r = 0: raw)
  std::vector<float> residuals;   // raw minus the median over (2 max(4, r) + 1)^2
};
SmoothedObstacle SmoothObstacle(const cv::Mat& view, const cv::Mat& obstacle, int radius);

// `shape` eroded by the silhouette margin (shrunk one pixel at a time while fewer than
// min_valid_pixels remain), within `obstacle`; all of `obstacle` if no margin leaves enough.
cv::Mat InteriorOf(const cv::Mat& shape, const cv::Mat& obstacle, const RangingOptions& options);

struct NearSurface {
  double disparity_px = 0.0;      // the near percentile of the smoothed interior values
  std::vector<float> values;      // the smoothed values it was taken over
  std::vector<cv::Point> points;  // their image coordinates
};
// The near percentile of the obstacle's interior (InteriorOf). With fill_rejected_holes, the
// interior of the obstacle with its holes of rejected pixels filled is taken instead when its
// percentile lies beyond surface_band_relative in front of the first.
NearSurface NearestSurface(const cv::Mat& view, const cv::Mat& obstacle,
                           const SmoothedObstacle& smoothed, cv::Point roi_origin, double offset,
                           const RangingOptions& options);

// 1-sigma uncertainty (px) of near.disparity_px: the floor, the percentile's standard error with
// correlated errors, the steepness of the tail and half the shift the silhouette pixels cause, in
// quadrature.
double NearSurfaceSigma(const NearSurface& near, const SmoothedObstacle& smoothed,
                        const RangingOptions& options);

}  // namespace linesight::detail
