// The naive reference of BodyMask (thin_structures.h) for the tests: every depth band worked on
// over the whole view, with OpenCV's morphology and distance transform.
#pragma once

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "linesight/core/disparity.h"
#include "linesight/ranging/thin_structures.h"

namespace linesight::testing {

inline cv::Mat NaiveBodyMask(const cv::Mat& disparity, const StereoGeometry& geometry,
                             const cv::Rect& region, const ThinStructureOptions& options,
                             bool seeds_only) {
  const cv::Rect image(0, 0, disparity.cols, disparity.rows);
  const DepthBands bands(geometry, options.min_depth_m, options.max_depth_m,
                         options.depth_band_relative);
  auto radius_of_band = [&](int k) {
    const double d = bands.CentreDisparity(k);
    return 0.5 * std::max(options.min_width_px,
                          options.min_width_m * geometry.focal_px / geometry.DepthFromDisparity(d));
  };
  double max_radius = 0.0;
  for (int y = region.y; y < region.br().y; ++y) {
    for (int x = region.x; x < region.br().x; ++x) {
      const float d = disparity.at<float>(y, x);
      if (IsValidDisparity(d) && d >= bands.d_low && d <= bands.d_high) {
        max_radius = std::max(max_radius, 0.5 * std::max(options.min_width_px,
                                                         options.min_width_m * (d + bands.offset) /
                                                             geometry.baseline_m));
      }
    }
  }
  const int margin = int(std::ceil(max_radius)) + 2;
  const cv::Rect outer =
      (region + cv::Size(2 * margin, 2 * margin) - cv::Point(margin, margin)) & image;
  const cv::Mat band_of = SurfaceBands(bands, disparity(outer));
  const bool at_border =
      outer.x == 0 || outer.y == 0 || outer.br().x == image.width || outer.br().y == image.height;
  cv::Mat body(band_of.size(), CV_8U, cv::Scalar(0));
  for (int k = 0; k < bands.count; ++k) {
    if (cv::countNonZero(band_of == k) == 0) continue;  // no seeds
    cv::Mat surface, padded, distance, grown;
    cv::inRange(band_of, k - 1, k + 1, surface);
    const int close = std::max(3, int(std::round(radius_of_band(k))) | 1);
    cv::morphologyEx(surface, surface, cv::MORPH_CLOSE,
                     cv::getStructuringElement(cv::MORPH_ELLIPSE, {close, close}));
    const int pad = at_border ? int(std::ceil(radius_of_band(k))) + 1 : 0;
    cv::copyMakeBorder(surface, padded, pad, pad, pad, pad, cv::BORDER_REPLICATE);
    cv::distanceTransform(padded, distance, cv::DIST_L2, cv::DIST_MASK_5);
    const double radius = radius_of_band(k);
    const cv::Mat seeds =
        (distance(cv::Rect(pad, pad, band_of.cols, band_of.rows)) >= radius) & (band_of == k);
    if (seeds_only) {
      body |= seeds;
      continue;
    }
    const int r = int(std::ceil(radius));
    cv::dilate(seeds, grown, cv::getStructuringElement(cv::MORPH_ELLIPSE, {2 * r + 1, 2 * r + 1}));
    body |= grown & surface;
  }
  return body(cv::Rect(region.x - outer.x, region.y - outer.y, region.width, region.height))
      .clone();
}

}  // namespace linesight::testing
