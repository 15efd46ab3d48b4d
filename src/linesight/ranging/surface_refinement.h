// Photometric refinement of an obstacle's front-surface disparity on the rectified images.
//
// Why: a matcher's window (census 7x5, SGM paths) reaches beyond a thin front surface -- the 12 mm
// glass rims of an insulator's sheds are 4 px tall at 2 m -- and blends in what lies behind, so the
// matched disparities of the nearest surface read systematically too small (too far), by 0.3 to
// 1.2 px in `linesight eval ranging --diagnose`. Matching the surface's pixels themselves, and
// nothing else, removes that: one disparity d for the whole pixel set S (the surface is taken as
// fronto-parallel across S, which holds for the obstacles' camera-facing fronts), maximising the
// normalised cross-correlation between L(x, y) and R(x - d, y) over S, with R interpolated by a
// cubic (Keys) kernel along the row. No pixel outside S enters, so there is no window to fatten
// across the surface's silhouette.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace linesight {

struct SurfaceRefinementOptions {
  // Search d0 - w .. d0 + w with w = search_px + search_relative * d0 (the matcher's bias on thin
  // fronts reaches 1.2 px at 1 m, 2.6 % of d).
  double search_px = 1.5;
  double search_relative = 0.02;
  double step_px = 0.05;  // grid step of the search before the parabola fit (px)
  int min_pixels = 30;    // fewer usable pixels in S -> not refined
  // The correlation peak must reach this NCC, else S is not refined: lower means one
  // fronto-parallel disparity does not explain S's appearance in both views (S mixes depth layers,
  // is partly occluded in the right view, or its texture aliases). `eval ranging --diagnose` on the
  // TRUE front pixels: damper end caps 0.88..0.94 and insulator rims 0.96..0.98 refine to within
  // 0.02..0.35 px, the clamp's fine-grained face (0.57..0.84) lands 0.2..0.6 px off.
  double min_ncc = 0.9;
  // Only pixels whose left-image gradient points within atan(gradient_ratio) of the row
  // direction, |dI/dy| <= gradient_ratio * |dI/dx| (0 = every pixel). A residual vertical
  // misalignment dy of the rectification moves a pixel's row match by dy * (dI/dy) / (dI/dx): on
  // the near-horizontal edges of an insulator's rims a 0.1 px misalignment of an estimated
  // calibration became a 1-2 % distance error (`eval ranging --runs 4`, estimated calibration,
  // insulator at 4 m: -1.78 % with every pixel, -0.02 % with ratio 1). Pixels without any
  // gradient pass (0 <= 0); they carry no disparity information and only add noise.
  double gradient_ratio = 1.0;
  // Only pixels of S whose four neighbours are in S too: a surface's border pixels mix it with
  // what lies beside or behind it (a 12 mm rim is 2-3 px tall at 4 m, nearly all border), which
  // pulls the fit towards the background.
  bool interior_only = true;

  void Check() const;
};

struct SurfaceRefinement {
  bool ok = false;
  std::string reason;       // why it was not refined (empty when ok)
  double disparity_px = 0;  // d maximising the NCC over S
  double sigma_px = 0;      // its noise standard error: sigma_e / sqrt(sum of (dR/dx)^2)
  double ncc = 0;           // the peak's NCC
  // Pixels of S used: those whose match stays inside the right image and that pass the gradient
  // and interior selection.
  int pixels = 0;
  // Not ok because the correlation is highest at an end of the search window: disparity_px and
  // ncc are then that end's (the true peak lies at or beyond it).
  bool at_search_edge = false;
};

// `left`, `right`: the rectified pair (8-bit grey or BGR, same size); `pixels`: S in left image
// coordinates; `d0`: the disparity to search around. Throws InputError for empty or mismatched
// images.
SurfaceRefinement RefineSurfaceDisparity(const cv::Mat& left, const cv::Mat& right,
                                         const std::vector<cv::Point>& pixels, double d0,
                                         const SurfaceRefinementOptions& options);

// Disparity of a front surface's silhouette edges, measured on each view separately.
//
// Why: a small front with no texture of its own (a damper's dark end cap, 10 px across at 4.5 m)
// carries its disparity only in its outline. A window -- the matcher's or RefineSurfaceDisparity's
// -- that holds the outline also holds background that the other view does not see (half
// occlusion), and reads the front too far (`eval ranging --diagnose`: 0.2..0.5 px at the damper at
// 4.5 m). Here each view's edge is located on its own, per row, by the coverage of the step
// between the two plateaus beside it: with levels A (left plateau pixel a) and B (right plateau
// pixel b, one pixel beyond the last step above the noise on each side, so that a pixel the edge
// barely covers is counted) the edge lies at a + 1/2 + sum over a < x < b of (I(x) - B) / (A - B).
// That is exact for an area-sampled step whatever the background's level in either view, and stays
// exact under blur and under the rectification's bilinear resampling (a unit-gain filter keeps the
// step's first moment), which is what biases a correlation's subpixel peak. The row's disparity is
// the difference of the two views' edges.
//
// Which edges: per row of the surface set S (and row_extension_px rows beyond it), the strongest
// step near S's left end (searched from `reach_px` outside to `inward_px` inside), and the same
// for its right end. The step must be one
// monotone transition of at least `min_contrast` between flat plateaus, with the same polarity
// and the same inside (surface) level in both views, and nearly vertical (|dx/dy| of the edge over
// neighbouring rows at most `max_slope`: a residual vertical misalignment dy of the rectification
// shifts an oblique edge by dy * dx/dy). An end whose step fails any check (a surface edge against
// an equally dark neighbour, a texture too busy for plateaus) gives nothing. Each end's result is
// the median of its rows; where both ends have one and they agree, their mean, else the nearer end
// (larger disparity), as the nearest-surface distance asks for.
struct EdgeDisparityOptions {
  int reach_px = 7;   // outwards from S's row end (the silhouette margin keeps S 4 px inside)
  int inward_px = 1;  // inwards from S's row end
  // Rows above and below S searched too (the silhouette margin keeps S 3 rows inside), with the
  // ends and the surface level of S's nearest row.
  int row_extension_px = 3;
  int right_search_px = 3;     // search radius of the right view's edge around e_L - d0
  double min_contrast = 16.0;  // grey levels between the two plateaus
  // A plateau's neighbours differ from it by at most this fraction of the contrast: one pixel on
  // the outside, surface_plateau_px on the surface's side.
  double plateau_tolerance = 0.25;
  int surface_plateau_px = 3;
  // The two views' inside (surface) levels agree within this fraction of the contrast.
  double level_tolerance = 0.25;
  // A row's disparity lies within gate_px + gate_relative * d0 of d0 (the matched value).
  double gate_px = 0.5;
  double gate_relative = 0.03;
  double max_slope = 1.0;
  int min_rows = 4;  // per side

  void Check() const;
};

struct EdgeDisparity {
  bool ok = false;
  std::string reason;  // why not (empty when ok)
  // The ends' median row disparity: their row-weighted mean where both ends have min_rows rows
  // and agree, else the nearer end's.
  double disparity_px = 0;
  double sigma_px = 0;  // its standard error (median: 1.2533 * 1.4826 MAD / sqrt(rows))
  int rows = 0;         // rows it rests on
  int side = 0;         // -1 = S's left ends, +1 = right ends, 0 = both
  int left_rows = 0, right_rows = 0;  // rows with a clean edge at each end
};

// `left`, `right`: the rectified pair (8-bit grey or BGR); `pixels`: S; `d0`: the matched
// disparity (not ok unless finite and within the image width). Throws InputError for empty,
// mismatched or not 8-bit images.
EdgeDisparity MeasureEdgeDisparity(const cv::Mat& left, const cv::Mat& right,
                                   const std::vector<cv::Point>& pixels, double d0,
                                   const EdgeDisparityOptions& options);

}  // namespace linesight
