#include "linesight/ranging/thin_structures.h"

#include <cmath>

#include <opencv2/imgproc.hpp>

#include "linesight/core/disparity.h"
#include "linesight/core/error.h"

namespace linesight {

DepthBands::DepthBands(const StereoGeometry& geometry, double min_depth_m, double max_depth_m,
                       double band_width)
    : offset(geometry.disparity_offset_px),
      d_low(geometry.DisparityFromDepth(max_depth_m)),
      d_high(geometry.DisparityFromDepth(min_depth_m)),
      log_low(std::log(d_low + offset)),
      width(band_width),
      count(int(std::ceil((std::log(d_high + offset) - log_low) / width)) + 1) {}

cv::Mat DepthBands::Map(const cv::Mat& disparity) const {
  cv::Mat band_of(disparity.size(), CV_32S, cv::Scalar(-1));
  for (int y = 0; y < disparity.rows; ++y) {
    const float* d = disparity.ptr<float>(y);
    int* b = band_of.ptr<int>(y);
    for (int x = 0; x < disparity.cols; ++x) {
      if (IsValidDisparity(d[x]) && d[x] >= d_low && d[x] <= d_high) b[x] = Of(d[x]);
    }
  }
  return band_of;
}

void ThinStructureOptions::Check() const {
  CheckOption(min_width_m > 0.0, "ThinStructureOptions.min_width_m", min_width_m, "must be > 0");
  CheckOption(min_width_px >= 0.0 && min_width_px <= 64.0, "ThinStructureOptions.min_width_px",
              min_width_px, "must be in [0, 64]");
  CheckOption(depth_band_relative > 0.0 && depth_band_relative <= 0.5,
              "ThinStructureOptions.depth_band_relative", depth_band_relative,
              "must be in (0, 0.5]");
  CheckOption(min_depth_m > 0.0, "ThinStructureOptions.min_depth_m", min_depth_m, "must be > 0");
  CheckOption(max_depth_m > min_depth_m, "ThinStructureOptions.max_depth_m", max_depth_m,
              "must exceed min_depth_m");
}

cv::Mat BodyMask(const cv::Mat& disparity, const StereoGeometry& geometry, const cv::Rect& region,
                 const ThinStructureOptions& options, bool seeds_only) {
  options.Check();
  LS_CHECK(disparity.type() == CV_32FC1);
  const cv::Rect image(0, 0, disparity.cols, disparity.rows);
  LS_CHECK((region & image) == region);
  const DepthBands depth_bands(geometry, options.min_depth_m, options.max_depth_m,
                               options.depth_band_relative);
  const double offset = depth_bands.offset;
  const double d_low = depth_bands.d_low, d_high = depth_bands.d_high;
  const int bands = depth_bands.count;
  auto radius_of_band = [&](int k) {
    const double d = depth_bands.CentreDisparity(k);
    return 0.5 * std::max(options.min_width_px,
                          options.min_width_m * geometry.focal_px / geometry.DepthFromDisparity(d));
  };
  // Work on the region plus a margin as wide as the largest body radius that occurs in it.
  double max_radius = 0.0;
  const cv::Mat inner = disparity(region);
  for (int y = 0; y < inner.rows; ++y) {
    const float* d = inner.ptr<float>(y);
    for (int x = 0; x < inner.cols; ++x) {
      if (IsValidDisparity(d[x]) && d[x] >= d_low && d[x] <= d_high) {
        max_radius = std::max(
            max_radius, 0.5 * std::max(options.min_width_px, options.min_width_m * (d[x] + offset) /
                                                                 geometry.baseline_m));
      }
    }
  }
  const int margin = int(std::ceil(max_radius)) + 2;
  const cv::Rect outer =
      (region + cv::Size(2 * margin, 2 * margin) - cv::Point(margin, margin)) & image;
  const cv::Mat view = disparity(outer);
  const cv::Mat band_of = depth_bands.Map(view);
  // Each band's bounding box: a band's surface, its closing, distances and growth only reach a
  // few radii beyond it, so each band is worked on inside that box plus a margin, not on the whole
  // view (the result is the same pixel for pixel; the reference test checks this).
  std::vector<cv::Rect> box_of(static_cast<size_t>(bands));
  for (int y = 0; y < band_of.rows; ++y) {
    const int* b = band_of.ptr<int>(y);
    for (int x = 0; x < band_of.cols; ++x) {
      if (b[x] >= 0) box_of[size_t(b[x])] |= cv::Rect(x, y, 1, 1);
    }
  }
  const cv::Rect whole(0, 0, view.cols, view.rows);
  // The image border is not a surface edge: it clips bodies, it does not make them thin.
  const bool at_border =
      outer.x == 0 || outer.y == 0 || outer.br().x == image.width || outer.br().y == image.height;
  cv::Mat body(view.size(), CV_8U, cv::Scalar(0));
  cv::Mat surface, padded, distance, seeds, grown, in_band;
  for (int k = 0; k < bands; ++k) {
    if (box_of[size_t(k)].empty()) continue;
    cv::Rect box = box_of[size_t(k)];
    if (k > 0) box |= box_of[size_t(k - 1)];
    if (k + 1 < bands) box |= box_of[size_t(k + 1)];
    const double radius = radius_of_band(k);
    const int r = int(std::ceil(radius));
    // Matching leaves small holes inside bodies; a hole must not make a body look thin. Closing
    // with a disc of the body radius fills holes narrower than that radius without widening a
    // conductor.
    const int close = std::max(3, int(std::round(radius)) | 1);
    const int reach = close + r + 3;
    const cv::Rect crop = (box + cv::Size(2 * reach, 2 * reach) - cv::Point(reach, reach)) & whole;
    cv::inRange(band_of(crop), k - 1, k + 1, surface);
    cv::morphologyEx(surface, surface, cv::MORPH_CLOSE,
                     cv::getStructuringElement(cv::MORPH_ELLIPSE, {close, close}));
    // Beyond the view's own edges the surface continues (replicated), as if the view went on.
    const int pad = at_border ? r + 1 : 0;
    cv::copyMakeBorder(surface, padded, pad, pad, pad, pad, cv::BORDER_REPLICATE);
    cv::distanceTransform(padded, distance, cv::DIST_L2, cv::DIST_MASK_5);
    cv::compare(band_of(crop), k, in_band, cv::CMP_EQ);
    seeds = (distance(cv::Rect(pad, pad, crop.width, crop.height)) >= radius) & in_band;
    if (cv::countNonZero(seeds) == 0) continue;
    cv::Mat target = body(crop);
    if (seeds_only) {
      target |= seeds;
      continue;
    }
    cv::dilate(seeds, grown, cv::getStructuringElement(cv::MORPH_ELLIPSE, {2 * r + 1, 2 * r + 1}));
    target |= grown & surface;
  }
  return body(cv::Rect(region.x - outer.x, region.y - outer.y, region.width, region.height))
      .clone();
}

}  // namespace linesight
