// Thin structures (conductors, cables) versus bodies (obstacles) in a disparity map. A pixel lies
// on a body if the surface of similar depth around it is at least `min_width_m` wide (in metres at
// that depth) in every direction, or if it is within that half-width of such a pixel on the same
// surface (a morphological opening per depth band). Conductors (~27 mm) fall out with min_width_m ~
// 45 mm; damper weights, clamps and insulator sheds stay.
#pragma once

#include <algorithm>
#include <cmath>
#include <functional>

#include <opencv2/core.hpp>

#include "linesight/geometry/depth.h"

namespace linesight {

// Bands of equal relative depth over a working range: ln(d + doffs) from the far end in steps of
// `width`, for the disparities d of depths [min_depth_m, max_depth_m].
struct DepthBands {
  DepthBands(const StereoGeometry& geometry, double min_depth_m, double max_depth_m, double width);
  double offset, d_low, d_high, log_low, width;
  int count;

  // The band of a finite disparity inside [d_low, d_high].
  int Of(double d) const {
    return std::clamp(int((std::log(d + offset) - log_low) / width), 0, count - 1);
  }
  // The disparity at the centre of band k.
  double CentreDisparity(int k) const { return std::exp(log_low + (k + 0.5) * width) - offset; }
  // CV_32S map of every pixel's band, -1 where the disparity is invalid or outside the range.
  cv::Mat Map(const cv::Mat& disparity) const;
};

// The bands of the body test's surfaces: DepthBands::Map, with the pixels beyond the far end of
// the range (valid disparities below d_low) left at -1, which the farthest band's surface (bands
// -1..1) takes in, and the pixels without a disparity or nearer than the range at kNoSurface,
// which no band's does. The far background continues past the range's end, so where it crosses
// it, it stays a wide surface; the sky beside a far conductor is no surface at all.
constexpr int kNoSurface = -2;
cv::Mat SurfaceBands(const DepthBands& bands, const cv::Mat& disparity);

struct ThinStructureOptions {
  double min_width_m = 0.045;  // narrower surfaces are thin (m)
  // ... or narrower than this many pixels (0 = off): a matcher widens a thin structure by about
  // its window half-width on each side, so far away a conductor looks wider than min_width_m.
  double min_width_px = 0.0;
  double depth_band_relative =
      0.04;                  // width of a depth band in ln(d); a surface spans 3 neighbouring bands
  double min_depth_m = 0.2;  // pixels outside the depth range are ignored (m)
  double max_depth_m = 8.0;

  void Check() const;
};

// Binary morphology (CV_8UC1, 0 / 255) with OpenCV's n x n MORPH_ELLIPSE element (n odd), the
// same pixels as cv::dilate / cv::erode / cv::morphologyEx(MORPH_CLOSE) with it and their default
// borders (thin_structures_test checks this on awkward sizes), at a cost that grows with n, not
// n^2: the element is a row of centred column runs, and a pixel is in a run's dilation when the
// vertical distance to the nearest set pixel of that column is at most the run's half-height.
struct EllipseScratch {
  cv::Mat near, wide, complement, dilated;
};
void DilateEllipse(const cv::Mat& src, int n, cv::Mat* out, EllipseScratch* scratch);
void ErodeEllipse(const cv::Mat& src, int n, cv::Mat* out, EllipseScratch* scratch);
void CloseEllipse(const cv::Mat& src, int n, cv::Mat* out, EllipseScratch* scratch);

// Pixels nearer than `radius` to a set pixel of `off` (CV_8UC1, 0 / 255) in OpenCV's 5x5 chamfer
// distance: exactly where cv::distanceTransform(complement of off, DIST_L2, DIST_MASK_5) is below
// `radius` (outside the image counts as clear), as a dilation by the chamfer ball.
void NearerThan(const cv::Mat& off, double radius, cv::Mat* out, EllipseScratch* scratch);

// Returns (CV_8U, 255 = on a body) for `region` of the disparity; the pixels around `region` are
// looked at too, so that the region's border does not cut a body. With `seeds_only` the result
// holds only the pixels deep inside a body (before growing back), which is what automatic obstacle
// finding starts from.
//
// With `needed`, only some pixels must come out right: needed(d_from, d_to) bounds (in disparity
// map coordinates) the pixels with disparities in [d_from, d_to] whose result is used (an empty
// rectangle: none). The pixels inside those bounds are the same as without `needed`; the ones
// outside may differ. The cost shrinks with the bounds.
//
// Cost: each depth band is worked on around the clusters of 16 x 16 tiles that hold its surface,
// each with the margin its result depends on, so stray matches scattered over the image at some
// depth cost little.
using BandRegion = std::function<cv::Rect(double d_from, double d_to)>;
cv::Mat BodyMask(const cv::Mat& disparity, const StereoGeometry& geometry, const cv::Rect& region,
                 const ThinStructureOptions& options, bool seeds_only = false,
                 const BandRegion& needed = {});

}  // namespace linesight
