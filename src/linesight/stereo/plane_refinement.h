// ISGM refinement: least-squares disparity planes inside superpixels of the left image.
//
// Stages (each a free function in linesight::detail):
//  1. SegmentSuperpixels: superpixels of the left image (superpixels.h).
//  2. BuildSegmentIndex: pixel lists per segment.
//  3. FitSegmentPlanes: per segment a robust plane d = a*x + b*y + c through its valid
//     disparities: RANSAC on a deterministic sample, then iterated least squares on the inliers
//     (3x3 normal equations); validated by inlier ratio, residual RMS and slant. A segment that one
//     plane does not explain may take two planes (it straddles a depth edge) or none.
//  4. AdoptNeighbourPlanes: a segment without a plane of its own takes the plane of an adjacent
//     segment that explains its valid disparities.
//  5. ApplySegmentPlanes: outliers (far from the accepted plane) and holes take the plane value.
//  6. FillFromBackground (disparity_fill.h): what is still invalid takes the smaller (background)
//     disparity of the nearest valid pixels left and right on its row (Hirschmueller's occlusion
//     filling), so the result is 100 % dense.
//  7. A final median (cv::medianBlur over row stripes in parallel,
//  PlaneRefinementOptions::median_size).
// Every stage is deterministic and independent of the thread count (per-segment work writes only
// its own pixels; RANSAC draws from a generator seeded by the segment number).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "linesight/stereo/superpixels.h"

namespace linesight {

struct PlaneRefinementOptions {
  // Segmentation of the left image.
  SuperpixelOptions superpixels;
  // px: a disparity within this distance of a plane supports it (RANSAC scoring and refits), > 0.
  double inlier_threshold = 1.0;
  // px: a valid disparity farther than this from its segment's accepted plane is a mismatch and is
  // replaced by the plane value, >= inlier_threshold.
  double outlier_threshold = 2.0;
  // Minimum number of valid disparities for fitting a plane, >= 3.
  int min_support = 10;
  // Minimum fraction of a segment's pixels that must be valid for a fit, in [0, 1].
  double min_support_ratio = 0.2;
  // Fraction of a segment's valid disparities that its plane(s) must explain, in (0, 1].
  double min_inlier_ratio = 0.65;
  // px: largest RMS residual of the inliers of an accepted plane, > 0.
  double max_residual_rms = 0.6;
  // px/px: largest |a| and |b| of an accepted plane, > 0.
  double max_slant = 1.5;
  // Random 3-point hypotheses per segment, >= 0 (the fronto-parallel median is always tried).
  int ransac_iterations = 20;
  // Pixels scored per hypothesis (an even subsample of larger segments), >= 8.
  int ransac_max_points = 48;
  // Least-squares refits on the re-selected inliers, >= 1.
  int refit_iterations = 3;
  // A segment that one plane cannot explain may take two (a depth edge inside it).
  bool two_plane_fallback = true;
  // Mean number of 4-neighbours (0..4) that the second plane's pixels have among themselves: a
  // second surface must be a region (even a 1-px wire scores 2), not scattered mismatches that
  // happen to agree on a plane, >= 0.
  double min_surface_coherence = 1.5;
  // Fraction of a segment's valid disparities the second plane must explain, in [0, 1]: a thin band
  // of foreground disparities along the segment border is usually the matcher's foreground
  // fattening rather than a second surface.
  double min_second_plane_ratio = 0.0;
  // px, 0 = off. With the right image: in a two-plane segment each matched pixel takes the plane
  // whose warp matches the images better over a (2r+1)^2 window restricted to the segment. Off by
  // default: it measured slightly worse on every benchmark set (README).
  int photometric_radius = 0;
  // Grey levels at which the per-channel absolute difference of the photometric test saturates,
  // >= 1.
  int photometric_truncation = 30;
  // Segments without a plane of their own try the planes of adjacent segments.
  bool adopt_neighbour_planes = true;
  // Also replace valid disparities near the plane (within outlier_threshold) by the plane value.
  bool snap_inliers = false;
  // px: window of the median filter over the final dense map, 0 or 1 = off, 3 or 5.
  int median_size = 5;

  void Check() const;
  nlohmann::json ToJson() const;
};

struct PlaneRefinementStats {
  int segments = 0;
  int planar_segments = 0;       // one plane of their own
  int two_plane_segments = 0;    // two planes (straddling a depth edge)
  int adopted_segments = 0;      // a neighbour's plane
  int unexplained_segments = 0;  // no plane: disparities kept, holes filled from the background
  int64_t outliers_replaced = 0;
  int64_t holes_filled_by_plane = 0;
  int64_t holes_filled_from_background = 0;
  double superpixel_ms = 0, plane_fit_ms = 0, fill_ms = 0;

  nlohmann::json ToJson() const;
};

// disparity: CV_32FC1, +inf = invalid; left_image: the matched left image (8-bit grey or BGR), same
// size. Returns a dense CV_32FC1 disparity whose values stay within the range of the input's valid
// values (an input without any valid pixel gives all zeros).
cv::Mat RefineDisparityWithPlanes(const cv::Mat& disparity, const cv::Mat& left_image,
                                  const PlaneRefinementOptions& options,
                                  PlaneRefinementStats* stats = nullptr);

// As above; right_image (same size and type as the left, or empty) lets the images decide which
// surface a matched pixel of a two-plane segment is on
// (PlaneRefinementOptions::photometric_radius).
cv::Mat RefineDisparityWithPlanes(const cv::Mat& disparity, const cv::Mat& left_image,
                                  const cv::Mat& right_image, const PlaneRefinementOptions& options,
                                  PlaneRefinementStats* stats = nullptr);

namespace detail {

// d = a*x + b*y + c in absolute pixel coordinates.
struct DisparityPlane {
  double a = 0, b = 0, c = 0;
  double At(double x, double y) const { return a * x + b * y + c; }
};

// Sums of the least-squares normal equations for d ~ a*x + b*y + c. Coordinates are taken relative
// to an origin (ox, oy) so that the sums stay well conditioned.
struct PlaneNormalEquations {
  double sxx = 0, sxy = 0, syy = 0, sx = 0, sy = 0, n = 0, sxd = 0, syd = 0, sd = 0;
  void Add(double x, double y, double d) {
    sxx += x * x, sxy += x * y, syy += y * y, sx += x, sy += y, n += 1;
    sxd += x * d, syd += y * d, sd += d;
  }
};

struct PlanePoint {
  float x, y, d;
};

// Pixel indices (y * width + x) of every segment: segment s owns pixels[offsets[s] ..
// offsets[s+1]).
struct SegmentIndex {
  std::vector<int32_t> offsets;
  std::vector<int32_t> pixels;
  std::vector<int32_t> x, y;  // column and row of pixels[i] (no division per use)
  int Size(int segment) const { return offsets[segment + 1] - offsets[segment]; }
};

enum class SegmentModelKind : uint8_t { kNone, kPlane, kTwoPlanes, kAdopted };

struct SegmentModel {
  SegmentModelKind kind = SegmentModelKind::kNone;
  std::array<DisparityPlane, 2> planes;
  int valid = 0;    // valid disparities in the segment
  int inliers = 0;  // of those, explained by the model
};

SegmentIndex BuildSegmentIndex(const cv::Mat& labels, int num_segments);

// Accumulates the normal equations of `points` about origin (ox, oy).
PlaneNormalEquations AccumulateNormalEquations(const std::vector<PlanePoint>& points,
                                               const std::vector<uint8_t>* selected, double ox,
                                               double oy);

// Least-squares plane from the normal equations about (ox, oy); false when the points do not
// determine a plane (fewer than 3 or collinear).
bool SolvePlane(const PlaneNormalEquations& equations, double ox, double oy, DisparityPlane* plane);

// Number of points i < padded with |plane.At(x[i], y[i]) - d[i]| <= threshold (SIMD,
// plane_kernels.cc). `padded` is a multiple of kPlanePointPadding; padding points carry d = NaN,
// which never counts.
inline constexpr size_t kPlanePointPadding = 16;
int CountPlaneInliers(const double* x, const double* y, const double* d, size_t padded,
                      const DisparityPlane& plane, double threshold);

struct RobustPlaneFit {
  DisparityPlane plane;
  int inliers = 0;
  double residual_rms = 0;  // px, over the inliers
  std::vector<uint8_t> inlier_mask;
};

// RANSAC (plus the fronto-parallel median hypothesis) then least-squares refits on the inliers.
// Returns false if no hypothesis within the slant limit exists.
bool FitPlaneRobust(const std::vector<PlanePoint>& points, const PlaneRefinementOptions& options,
                    uint64_t seed, RobustPlaneFit* fit);

std::vector<SegmentModel> FitSegmentPlanes(const cv::Mat& disparity, const SegmentIndex& index,
                                           const PlaneRefinementOptions& options);

void AdoptNeighbourPlanes(const cv::Mat& disparity, const cv::Mat& labels,
                          const SegmentIndex& index, const PlaneRefinementOptions& options,
                          std::vector<SegmentModel>* models);

// Writes plane values over outliers and holes of every segment with a model (in two-plane segments
// holes take the surface that encloses them along the row, or the background between two surfaces).
// Values are clamped to [min_value, max_value].
// Matching evidence for choosing between the two planes of a segment.
struct SegmentPhotometry {
  cv::Mat left, right;  // 8-bit, same size and type (grey or BGR)
  cv::Mat labels;       // CV_32SC1 superpixel labels, continuous
  int radius = 2;       // window radius (px)
  int truncation = 30;  // per-channel truncation of the absolute difference (grey levels)
  // Mean truncated absolute difference between the left pixels of `segment` in the window around
  // (x, y) and the right image (linearly interpolated) at x - plane(x, y); a pixel mapped outside
  // costs the truncation.
  float Cost(int x, int y, int segment, const DisparityPlane& plane) const;
};

void ApplySegmentPlanes(const SegmentIndex& index, const std::vector<SegmentModel>& models,
                        const PlaneRefinementOptions& options, const SegmentPhotometry* photometry,
                        float min_value, float max_value, cv::Mat* disparity,
                        PlaneRefinementStats* stats);

// cv::medianBlur(src, ksize) computed over row stripes in parallel (OpenCV's float median runs on
// one thread); each stripe is filtered with the ksize / 2 rows of context it needs, so the result
// is identical to cv::medianBlur for any thread count.
cv::Mat MedianBlurStripes(const cv::Mat& src, int ksize);

}  // namespace detail
}  // namespace linesight
