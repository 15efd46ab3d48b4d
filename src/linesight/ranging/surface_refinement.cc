#include "linesight/ranging/surface_refinement.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "linesight/core/error.h"

namespace linesight {

void SurfaceRefinementOptions::Check() const {
  CheckOption(search_px >= 0.0 && search_px <= 16.0, "SurfaceRefinementOptions.search_px",
              search_px, "must be in [0, 16]");
  CheckOption(search_relative >= 0.0 && search_relative <= 0.2,
              "SurfaceRefinementOptions.search_relative", search_relative, "must be in [0, 0.2]");
  CheckOption(step_px > 0.0 && step_px <= 0.5, "SurfaceRefinementOptions.step_px", step_px,
              "must be in (0, 0.5]");
  CheckOption(min_pixels >= 3, "SurfaceRefinementOptions.min_pixels", min_pixels, "must be >= 3");
  CheckOption(min_ncc >= -1.0 && min_ncc < 1.0, "SurfaceRefinementOptions.min_ncc", min_ncc,
              "must be in [-1, 1)");
  CheckOption(gradient_ratio >= 0.0 && gradient_ratio <= 100.0,
              "SurfaceRefinementOptions.gradient_ratio", gradient_ratio, "must be in [0, 100]");
}

void EdgeDisparityOptions::Check() const {
  CheckOption(reach_px >= 1 && reach_px <= 32, "EdgeDisparityOptions.reach_px", reach_px,
              "must be in [1, 32]");
  CheckOption(inward_px >= 0 && inward_px <= 32, "EdgeDisparityOptions.inward_px", inward_px,
              "must be in [0, 32]");
  CheckOption(row_extension_px >= 0 && row_extension_px <= 32,
              "EdgeDisparityOptions.row_extension_px", row_extension_px, "must be in [0, 32]");
  CheckOption(right_search_px >= 1 && right_search_px <= 16, "EdgeDisparityOptions.right_search_px",
              right_search_px, "must be in [1, 16]");
  CheckOption(min_contrast > 0.0, "EdgeDisparityOptions.min_contrast", min_contrast, "must be > 0");
  CheckOption(plateau_tolerance > 0.0 && plateau_tolerance <= 1.0,
              "EdgeDisparityOptions.plateau_tolerance", plateau_tolerance, "must be in (0, 1]");
  CheckOption(level_tolerance > 0.0 && level_tolerance <= 1.0,
              "EdgeDisparityOptions.level_tolerance", level_tolerance, "must be in (0, 1]");
  CheckOption(gate_px >= 0.0, "EdgeDisparityOptions.gate_px", gate_px, "must be >= 0");
  CheckOption(gate_relative >= 0.0 && gate_relative <= 0.5, "EdgeDisparityOptions.gate_relative",
              gate_relative, "must be in [0, 0.5]");
  CheckOption(max_slope > 0.0, "EdgeDisparityOptions.max_slope", max_slope, "must be > 0");
  CheckOption(surface_plateau_px >= 1 && surface_plateau_px <= 16,
              "EdgeDisparityOptions.surface_plateau_px", surface_plateau_px, "must be in [1, 16]");
  CheckOption(min_rows >= 1, "EdgeDisparityOptions.min_rows", min_rows, "must be >= 1");
}

namespace {

cv::Mat ToGrayFloat(const cv::Mat& image) {
  cv::Mat gray;
  if (image.channels() == 3) {
    cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  } else if (image.channels() == 1) {
    gray = image;
  } else {
    throw InputError(
        fmt::format("expected a grey or BGR image, got {} channels", image.channels()));
  }
  cv::Mat out;
  gray.convertTo(out, CV_32F);
  return out;
}

// Throws InputError unless the pair is non-empty and of one size.
void CheckPair(const cv::Mat& left, const cv::Mat& right, const char* what) {
  if (left.empty() || right.empty()) throw InputError(fmt::format("{}: empty image", what));
  if (left.size() != right.size()) {
    throw InputError(fmt::format("{}: left {}x{} and right {}x{} differ", what, left.cols,
                                 left.rows, right.cols, right.rows));
  }
}

// Keys cubic convolution (a = -0.5) weights for the taps at -1, 0, 1, 2 around t in [0, 1).
void CubicWeights(double t, double w[4]) {
  const double a = -0.5;
  auto near = [&](double s) { return ((a + 2) * s - (a + 3)) * s * s + 1; };       // |s| <= 1
  auto far = [&](double s) { return ((a * s - 5 * a) * s + 8 * a) * s - 4 * a; };  // 1 < |s| < 2
  w[0] = far(1 + t);
  w[1] = near(t);
  w[2] = near(1 - t);
  w[3] = far(2 - t);
}

// R at x along the row (taps row[i - 1 .. i + 2], i = floor(x), must exist).
double SampleRow(const float* row, double x) {
  const int i = int(std::floor(x));
  double w[4];
  CubicWeights(x - i, w);
  double value = 0;
  for (int k = 0; k < 4; ++k) value += w[k] * row[i - 1 + k];
  return value;
}

double Ncc(const std::vector<double>& l, const std::vector<double>& r) {
  const size_t n = l.size();
  double ml = 0, mr = 0;
  for (size_t i = 0; i < n; ++i) ml += l[i], mr += r[i];
  ml /= double(n);
  mr /= double(n);
  double sll = 0, srr = 0, slr = 0;
  for (size_t i = 0; i < n; ++i) {
    sll += (l[i] - ml) * (l[i] - ml);
    srr += (r[i] - mr) * (r[i] - mr);
    slr += (l[i] - ml) * (r[i] - mr);
  }
  if (sll <= 0 || srr <= 0) return -1.0;
  return slr / std::sqrt(sll * srr);
}

}  // namespace

SurfaceRefinement RefineSurfaceDisparity(const cv::Mat& left, const cv::Mat& right,
                                         const std::vector<cv::Point>& pixels, double d0,
                                         const SurfaceRefinementOptions& options) {
  options.Check();
  CheckPair(left, right, "surface refinement");
  SurfaceRefinement out;
  const double w = options.search_px + options.search_relative * std::abs(d0);
  const int steps = int(std::ceil(w / options.step_px));
  const double d_min = d0 - steps * options.step_px, d_max = d0 + steps * options.step_px;
  // Only the rows S covers are converted.
  int y0 = left.rows, y1 = -1;
  for (const cv::Point& p : pixels) y0 = std::min(y0, p.y), y1 = std::max(y1, p.y);
  if (y1 < y0) {
    out.reason = "no surface pixels";
    return out;
  }
  const cv::Mat l = ToGrayFloat(left.rowRange(y0, y1 + 1));
  // Gradients of the left image (3x3 Sobel on the rows S covers, one row of context each side).
  cv::Mat gx, gy;
  int g0 = 0;
  if (options.gradient_ratio > 0) {
    g0 = std::max(0, y0 - 1);
    const cv::Mat lg = ToGrayFloat(left.rowRange(g0, std::min(left.rows, y1 + 2)));
    cv::Sobel(lg, gx, CV_32F, 1, 0, 3);
    cv::Sobel(lg, gy, CV_32F, 0, 1, 3);
  }
  const cv::Mat r = ToGrayFloat(right.rowRange(y0, y1 + 1));
  // Usable pixels: inside the image, and their match at every searched d inside the right image
  // with the interpolation taps.
  cv::Mat in_s;
  if (options.interior_only) {
    in_s = cv::Mat::zeros(y1 - y0 + 3, left.cols + 2, CV_8U);  // one guard pixel each side
    for (const cv::Point& p : pixels) {
      if (p.x >= 0 && p.x < left.cols) in_s.at<uchar>(p.y - y0 + 1, p.x + 1) = 1;
    }
  }
  auto interior = [&](const cv::Point& p) {
    const int u = p.x + 1, v = p.y - y0 + 1;
    return in_s.at<uchar>(v - 1, u) && in_s.at<uchar>(v + 1, u) && in_s.at<uchar>(v, u - 1) &&
           in_s.at<uchar>(v, u + 1);
  };
  std::vector<cv::Point> used;
  std::vector<double> lv;
  for (const cv::Point& p : pixels) {
    if (p.x < 0 || p.x >= left.cols || p.y < 0 || p.y >= left.rows) continue;
    if (p.x - d_max - 0.5 < 1.0 || p.x - d_min + 0.5 >= double(right.cols) - 2.0) continue;
    if (options.interior_only && !interior(p)) continue;
    if (options.gradient_ratio > 0 &&
        std::abs(gy.at<float>(p.y - g0, p.x)) >
            options.gradient_ratio * std::abs(gx.at<float>(p.y - g0, p.x))) {
      continue;
    }
    used.push_back({p.x, p.y - y0});
    lv.push_back(l.at<float>(p.y - y0, p.x));
  }
  out.pixels = int(used.size());
  if (out.pixels < options.min_pixels) {
    out.reason = fmt::format(
        "only {} surface pixels are usable (match inside the right image, "
        "gradient and interior selection); need {}",
        out.pixels, options.min_pixels);
    return out;
  }
  std::vector<double> rv(used.size());
  auto ncc_at = [&](double d) {
    for (size_t i = 0; i < used.size(); ++i)
      rv[i] = SampleRow(r.ptr<float>(used[i].y), used[i].x - d);
    return Ncc(lv, rv);
  };
  std::vector<double> scores(size_t(2 * steps + 1));
  int best = 0;
  for (int k = 0; k <= 2 * steps; ++k) {
    scores[size_t(k)] = ncc_at(d_min + k * options.step_px);
    if (scores[size_t(k)] > scores[size_t(best)]) best = k;
  }
  if (best == 0 || best == 2 * steps) {
    out.reason = fmt::format("the correlation peaks at the edge of the search {:.2f}..{:.2f} px",
                             d_min, d_max);
    out.at_search_edge = true;
    out.disparity_px = d_min + best * options.step_px;
    out.ncc = scores[size_t(best)];
    return out;
  }
  // Parabola through the best grid point and its neighbours, then the peak itself.
  const double a = scores[size_t(best - 1)], b = scores[size_t(best)], c = scores[size_t(best + 1)];
  const double denom = a - 2 * b + c;
  const double shift = denom < 0 ? std::clamp(0.5 * (a - c) / denom, -0.5, 0.5) : 0.0;
  out.disparity_px = d_min + (best + shift) * options.step_px;
  out.ncc = ncc_at(out.disparity_px);
  if (!(out.ncc >= options.min_ncc)) {
    out.reason =
        fmt::format("the correlation peak {:.2f} is below {:.2f}: not one textured surface",
                    out.ncc, options.min_ncc);
    return out;
  }
  // Noise: residual of the affine fit L = alpha + beta R at the peak, against sum of (beta
  // dR/dx)^2.
  double ml = 0, mr = 0;
  for (size_t i = 0; i < used.size(); ++i) ml += lv[i], mr += rv[i];
  ml /= double(used.size());
  mr /= double(used.size());
  double srr = 0, slr = 0;
  for (size_t i = 0; i < used.size(); ++i) {
    srr += (rv[i] - mr) * (rv[i] - mr);
    slr += (lv[i] - ml) * (rv[i] - mr);
  }
  const double beta = srr > 0 ? slr / srr : 1.0;
  double see = 0, sgg = 0;
  for (size_t i = 0; i < used.size(); ++i) {
    const double e = (lv[i] - ml) - beta * (rv[i] - mr);
    see += e * e;
    const float* row = r.ptr<float>(used[i].y);
    const double x = used[i].x - out.disparity_px;
    // dR/dx: central difference of the interpolant over one pixel.
    const double g = SampleRow(row, x + 0.5) - SampleRow(row, x - 0.5);
    sgg += beta * beta * g * g;
  }
  const double sigma_e = std::sqrt(see / double(std::max<size_t>(1, used.size() - 2)));
  out.sigma_px = sgg > 0 ? sigma_e / std::sqrt(sgg) : std::numeric_limits<double>::infinity();
  out.ok = true;
  return out;
}

namespace {

// One step in a row profile: the transition between the plateau pixels a and b (a < b).
struct Step {
  double edge = 0;          // subpixel position of the step (coverage)
  double inside_level = 0;  // the level on the surface's side
  double contrast = 0;      // |B - A|
  int sign = 0;             // sign of B - A
};

// The strongest step between x and x + 1 for x in [lo, hi] (of sign `sign` unless 0), grown to its
// monotone transition; nullopt unless it passes the contrast and plateau checks. The surface lies
// on the step's right side if `inside_right`.
std::optional<Step> FindStep(const float* p, int n, int lo, int hi, int sign, bool inside_right,
                             const EdgeDisparityOptions& o) {
  lo = std::max(lo, 2);
  hi = std::min(hi, n - 4);
  int k = -1;
  double peak = 0;
  for (int x = lo; x <= hi; ++x) {
    const double diff = double(p[x + 1]) - double(p[x]);
    const double strength = sign == 0 ? std::abs(diff) : sign * diff;
    if (strength > peak) peak = strength, k = x;
  }
  if (k < 0) return std::nullopt;
  const int s = p[k + 1] > p[k] ? 1 : -1;
  // The transition: steps of the same sign above the noise. A pixel the edge barely covers
  // differs from its plateau by less than that, so the plateau pixels are the next ones out: a
  // pixel with coverage c left out would move the edge by c.
  const double t = std::max(3.0, 0.1 * peak);
  int first = k, last = k + 1;
  while (first >= 3 && s * (double(p[first]) - double(p[first - 1])) > t) --first;
  while (last <= n - 4 && s * (double(p[last + 1]) - double(p[last])) > t) ++last;
  constexpr int kMaxTransitionPx = 6;
  if (last - first > kMaxTransitionPx) return std::nullopt;
  const int a = first - 1, b = last + 1;  // >= 1 and <= n - 2
  const double level_a = p[a], level_b = p[b];
  const double contrast = std::abs(level_b - level_a);
  if (contrast < o.min_contrast) return std::nullopt;
  // Flat plateaus: one pixel beyond on the outside, surface_plateau_px on the surface's side (the
  // edges measure textureless fronts; a textured surface has no level to measure against).
  auto flat = [&](int from, int step, int count, double level) {
    for (int i = 1; i <= count; ++i) {
      const int x = from + i * step;
      if (x < 0 || x >= n) return false;
      if (std::abs(double(p[x]) - level) > o.plateau_tolerance * contrast) return false;
    }
    return true;
  };
  if (!flat(a, -1, inside_right ? 1 : o.surface_plateau_px, level_a) ||
      !flat(b, 1, inside_right ? o.surface_plateau_px : 1, level_b)) {
    return std::nullopt;
  }
  Step step;
  step.edge = a + 0.5;
  for (int x = a + 1; x < b; ++x) step.edge += (double(p[x]) - level_b) / (level_a - level_b);
  step.inside_level = inside_right ? level_b : level_a;
  step.contrast = contrast;
  step.sign = s;
  return step;
}

double Median(std::vector<double> v) {
  const size_t m = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + long(m), v.end());
  return v[m];
}

}  // namespace

EdgeDisparity MeasureEdgeDisparity(const cv::Mat& left, const cv::Mat& right,
                                   const std::vector<cv::Point>& pixels, double d0,
                                   const EdgeDisparityOptions& options) {
  options.Check();
  CheckPair(left, right, "edge disparity");
  if (left.depth() != CV_8U || right.depth() != CV_8U) {
    throw InputError("edge disparity: expected 8-bit images (min_contrast is in grey levels)");
  }
  EdgeDisparity out;
  if (!std::isfinite(d0) || std::abs(d0) > double(left.cols)) {
    out.reason = fmt::format("the matched disparity {} is not inside the image", d0);
    return out;
  }
  // S's row ends.
  std::map<int, std::pair<int, int>> ends;  // y -> (min x, max x)
  for (const cv::Point& p : pixels) {
    if (p.x < 0 || p.x >= left.cols || p.y < 0 || p.y >= left.rows) continue;
    auto [it, inserted] = ends.try_emplace(p.y, p.x, p.x);
    if (!inserted) {
      it->second.first = std::min(it->second.first, p.x);
      it->second.second = std::max(it->second.second, p.x);
    }
  }
  if (ends.empty()) {
    out.reason = "no surface pixels";
    return out;
  }
  const int s0 = ends.begin()->first, s1 = ends.rbegin()->first;
  const int y0 = std::max(0, s0 - options.row_extension_px);
  const int y1 = std::min(left.rows - 1, s1 + options.row_extension_px);
  const cv::Mat l = ToGrayFloat(left.rowRange(y0, y1 + 1));
  const cv::Mat r = ToGrayFloat(right.rowRange(y0, y1 + 1));
  const int n = left.cols;
  const double gate = options.gate_px + options.gate_relative * std::abs(d0);
  std::vector<EdgeDisparity> sides;
  for (const int side : {-1, 1}) {
    const bool inside_right = side < 0;  // S's left end: the surface lies right of the step
    std::map<int, double> left_edges;    // y -> the left view's edge
    std::map<int, double> row_disparity;
    for (int y = y0; y <= y1; ++y) {
      // S's row, or the nearest one of S for the rows beyond it (S can skip rows: the next one
      // below).
      const int ys = std::clamp(y, s0, s1);
      const auto& [y_ref, xs] = *ends.lower_bound(ys);
      const float* pl = l.ptr<float>(y - y0);
      const float* pr = r.ptr<float>(y - y0);
      const int end = side < 0 ? xs.first : xs.second;
      const float surface_level = l.ptr<float>(y_ref - y0)[end];
      // Steps between x and x + 1 with the surface pixel (x + 1 or x) within inward_px inside
      // S's end and the outside pixel within reach_px outside it.
      const int lo = side < 0 ? end - options.reach_px : end - options.inward_px;
      const int hi = side < 0 ? end + options.inward_px - 1 : end + options.reach_px - 1;
      const std::optional<Step> sl = FindStep(pl, n, lo, hi, 0, inside_right, options);
      if (!sl) continue;
      // The inside must be S's own surface: its level that of S's end pixel.
      if (std::abs(sl->inside_level - surface_level) > options.level_tolerance * sl->contrast)
        continue;
      left_edges[y] = sl->edge;
      const int c = int(std::floor(sl->edge - d0));
      const std::optional<Step> sr =
          FindStep(pr, n, c - options.right_search_px, c + options.right_search_px, sl->sign,
                   inside_right, options);
      if (!sr) continue;
      if (std::abs(sr->inside_level - sl->inside_level) > options.level_tolerance * sl->contrast)
        continue;
      const double d = sl->edge - sr->edge;
      if (std::abs(d - d0) > gate) continue;
      row_disparity[y] = d;
    }
    // Nearly vertical edges only: a row needs a neighbouring row's edge within max_slope.
    std::vector<double> ds;
    for (const auto& [y, d] : row_disparity) {
      const auto up = left_edges.find(y - 1), down = left_edges.find(y + 1);
      double slope = std::numeric_limits<double>::infinity();
      const double e = left_edges[y];
      if (up != left_edges.end()) slope = std::abs(e - up->second);
      if (down != left_edges.end()) slope = std::min(slope, std::abs(down->second - e));
      if (slope <= options.max_slope) ds.push_back(d);
    }
    (side < 0 ? out.left_rows : out.right_rows) = int(ds.size());
    if (int(ds.size()) < options.min_rows) continue;
    EdgeDisparity e;
    e.side = side;
    e.rows = int(ds.size());
    e.disparity_px = Median(ds);
    std::vector<double> dev(ds.size());
    for (size_t i = 0; i < ds.size(); ++i) dev[i] = std::abs(ds[i] - e.disparity_px);
    // Standard error of a median: sqrt(pi / 2) times that of a mean, sigma from the MAD.
    e.sigma_px = 1.2533 * 1.4826 * Median(dev) / std::sqrt(double(ds.size()));
    e.ok = true;
    sides.push_back(e);
  }
  if (sides.empty()) {
    out.reason = fmt::format(
        "fewer than {} rows with a clean edge at either end of the surface ({} left, {} right)",
        options.min_rows, out.left_rows, out.right_rows);
    return out;
  }
  const int left_rows = out.left_rows, right_rows = out.right_rows;
  if (sides.size() == 1) {
    out = sides.front();
  } else {
    // Both ends: where they agree (within twice their combined error, each at least
    // kSidePrecisionPx: 8-bit levels and rows that share their plateaus), one surface -- their
    // row-weighted mean; else the nearer end, as the nearest-surface distance asks for.
    constexpr double kSidePrecisionPx = 0.05;
    const EdgeDisparity &ends_l = sides[0], &ends_r = sides[1];
    const double tolerance = 2.0 * std::hypot(std::max(ends_l.sigma_px, kSidePrecisionPx),
                                              std::max(ends_r.sigma_px, kSidePrecisionPx));
    if (std::abs(ends_l.disparity_px - ends_r.disparity_px) <= tolerance) {
      const double rows = ends_l.rows + ends_r.rows;
      out = ends_l;
      out.side = 0;
      out.rows = ends_l.rows + ends_r.rows;
      out.disparity_px =
          (ends_l.rows * ends_l.disparity_px + ends_r.rows * ends_r.disparity_px) / rows;
      out.sigma_px =
          std::hypot(ends_l.rows * ends_l.sigma_px, ends_r.rows * ends_r.sigma_px) / rows;
    } else {
      out = ends_l.disparity_px > ends_r.disparity_px ? ends_l : ends_r;
    }
  }
  out.left_rows = left_rows;
  out.right_rows = right_rows;
  return out;
}

}  // namespace linesight
