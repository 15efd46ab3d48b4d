#include "linesight/line/conductor_faults.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "linesight/core/disparity.h"
#include "linesight/core/error.h"
#include "linesight/line/thin_attachments.h"

namespace linesight {
namespace {

constexpr double kStep = 0.25;  // sampling step across the line (px)
// The band's disparity from its edges needs them to cross the rows: |x of the unit normal| >= this.
constexpr double kMinNormalX = 0.3;
constexpr int kAxisRounds = 4;  // measurements of the right view's band for the axis's disparity
// How far along the line an axis point may lie from its cross-section's point of the model (m).
constexpr double kMaxAxisArcShiftM = 0.1;

double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  const size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + mid, v.end());
  return v[mid];
}

// Bilinear sample of a CV_32FC1 image; false outside it.
bool Sample(const cv::Mat& image, double x, double y, double* value) {
  if (x < 0 || y < 0 || x > image.cols - 1.001 || y > image.rows - 1.001) return false;
  const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
  const double fx = x - x0, fy = y - y0;
  const float* r0 = image.ptr<float>(y0);
  const float* r1 = image.ptr<float>(y0 + 1);
  *value =
      (1 - fy) * ((1 - fx) * r0[x0] + fx * r0[x0 + 1]) + fy * ((1 - fx) * r1[x0] + fx * r1[x0 + 1]);
  return true;
}

// Nearest-pixel disparity (+inf outside the map).
float DisparityNear(const cv::Mat& disparity, double x, double y) {
  const int xi = static_cast<int>(std::lround(x)), yi = static_cast<int>(std::lround(y));
  if (xi < 0 || yi < 0 || xi >= disparity.cols || yi >= disparity.rows) {
    return std::numeric_limits<float>::infinity();
  }
  return disparity.at<float>(yi, xi);
}

cv::Mat GrayFloat(const cv::Mat& image) {
  cv::Mat gray, out;
  if (image.channels() == 3) {
    cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  } else {
    gray = image;
  }
  gray.convertTo(out, CV_32F);
  return out;
}

cv::Point3d PixelAtDepth(const StereoGeometry& g, double u, double v, double z) {
  return {(u - g.cx) * z / g.focal_px, (v - g.cy) * z / g.focal_px, z};
}

// The edge of the band on one side: where the profile, going outward from the band's centre
// index `c`, crosses half-way between `band` and `background` (sub-pixel, in samples). -1 when it
// does not within the profile.
double HalfCrossing(const std::vector<double>& profile, int c, int direction, double band,
                    double background) {
  const double half = 0.5 * (band + background);
  const double sign = band > background ? 1.0 : -1.0;
  for (int i = c; i + direction >= 0 && i + direction < static_cast<int>(profile.size());
       i += direction) {
    const double a = sign * (profile[i] - half), b = sign * (profile[i + direction] - half);
    if (a >= 0 && b < 0) return i + direction * a / (a - b);
  }
  return -1;
}

// One cross-section of the line in one view: the band's half-width and the protrusions beyond
// its edges (see the file comment). `p` is the line's image point, `n` the unit normal.
struct CrossSection {
  bool measured = false;
  double radius_px = 0;
  double edge_px[2] = {0, 0};  // distance of each edge from the line's point (px)
  double contrast = 0;
  double protrusion_px[2] = {0, 0};
  // The band's extent: how far from the line's point the profile, coming in from the background,
  // first leaves it (px, per side as edge_px); extent_found when both sides have one inside the
  // background ring.
  bool extent_found = false;
  double extent_px[2] = {0, 0};
};

CrossSection MeasureCrossSection(const cv::Mat& image, cv::Point2d p, cv::Point2d n,
                                 double expected_px, double window, double strand_px,
                                 const ConductorFaultOptions& o, std::vector<double>* scratch) {
  CrossSection out;
  const int half = static_cast<int>(std::ceil(window / kStep));
  const int count = 2 * half + 1;
  std::vector<double>& profile = *scratch;
  profile.assign(count, 0.0);
  for (int i = 0; i < count; ++i) {
    const double off = (i - half) * kStep;
    if (!Sample(image, p.x + off * n.x, p.y + off * n.y, &profile[i])) return out;
  }
  // Backgrounds: a ring on each side just beyond where the widest swelling looked for would end
  // (1.6 expected radii plus 2 px), a few pixels wide: the background next to the line, not the
  // horizon or a tower farther out in the window. The band: the sample nearest the curve that
  // differs most from both backgrounds, within the expected radius plus the fattening.
  const int ring_from = std::min(half - 4, static_cast<int>((1.6 * expected_px + 2) / kStep));
  const int ring_to =
      std::min(half, ring_from + static_cast<int>(std::max(4.0, expected_px) / kStep));
  std::vector<double> outer[2];
  for (int k = ring_from; k <= ring_to; ++k) {
    outer[0].push_back(profile[half + k]);
    outer[1].push_back(profile[half - k]);
  }
  const double background[2] = {Median(outer[0]), Median(outer[1])};
  const double mean_background = 0.5 * (background[0] + background[1]);
  const int reach = static_cast<int>((expected_px + o.fattening_px) / kStep);
  int centre = half;
  double best = -1;
  for (int i = std::max(0, half - reach); i <= std::min(count - 1, half + reach); ++i) {
    const double smoothed =
        (profile[std::max(0, i - 1)] + profile[i] + profile[std::min(count - 1, i + 1)]) / 3.0;
    const double score = std::fabs(smoothed - mean_background);
    if (score > best) {
      best = score;
      centre = i;
    }
  }
  const double band = profile[centre];
  out.contrast = std::min(std::fabs(band - background[0]), std::fabs(band - background[1]));
  const bool same_sign = (band - background[0]) * (band - background[1]) > 0;
  if (!same_sign || out.contrast < o.min_contrast) return out;
  const double e0 = HalfCrossing(profile, centre, +1, band, background[0]);
  const double e1 = HalfCrossing(profile, centre, -1, band, background[1]);
  if (e0 < 0 || e1 < 0) return out;
  // The extent on each side: coming in from the ring, the first sample that differs from the
  // background (towards the band's level) by extent_fraction of the contrast. Lit spread strands
  // are lighter than the conductor's shaded core, yet well off the background; what lies inside
  // the extent (the strands' texture, the gaps between them) does not matter. The rings are placed
  // about the band's centre (between the half-way crossings), not the model's point: the model's
  // image of the line may be off by a few pixels, and a swelling is round the conductor's axis.
  out.extent_found = true;
  const double sign = band > mean_background ? 1.0 : -1.0;
  const int mid = static_cast<int>(std::lround(0.5 * (e0 + e1)));
  const double mid_offset_px = (mid - half) * kStep;
  for (int side = 0; side < 2 && out.extent_found; ++side) {
    const int direction = side == 0 ? +1 : -1;
    auto at = [&](int k) { return profile[mid + direction * k]; };
    auto inside = [&](int k) { return mid + direction * k >= 0 && mid + direction * k < count; };
    std::vector<double> ring;
    for (int k = ring_from; k <= ring_to && inside(k); ++k) ring.push_back(at(k));
    if (ring.size() < 4) {
      out.extent_found = false;
      break;
    }
    const double level = Median(ring);
    const double threshold = o.extent_fraction * std::fabs(band - level);
    auto excess = [&](int k) { return sign * (at(k) - level) - threshold; };
    int k = ring_from - 1;
    if (excess(k) > 0) {  // the ring itself is not background next to the band
      out.extent_found = false;
      break;
    }
    while (k - 1 >= 0 && excess(k - 1) <= 0) --k;
    if (k - 1 < 0) {  // never leaves the background: no band on this side
      out.extent_found = false;
      break;
    }
    const double a = excess(k - 1), b = excess(k);  // a > 0 >= b
    out.extent_px[side] = (k - 1 + a / (a - b)) * kStep + direction * mid_offset_px;
  }
  const double edges[2] = {e0, e1};
  out.edge_px[0] = (e0 - half) * kStep;
  out.edge_px[1] = (half - e1) * kStep;
  out.measured = true;
  out.radius_px = 0.5 * (e0 - e1) * kStep;
  // Protrusions: thin bumps beyond each edge (past half the contrast, at most a few strand widths
  // wide, back to the background before the window ends). A level change that runs to the
  // window's end is the background's, not a strand.
  const double* edge = edges;
  const int max_bump = static_cast<int>((2 * strand_px + 2) / kStep);
  for (int side = 0; side < 2; ++side) {
    const int direction = side == 0 ? +1 : -1;
    const double c = band - background[side];
    int run_start = -1;
    int farthest = -1;
    for (int i = static_cast<int>(std::ceil(edge[side])) + direction; i >= 0 && i < count;
         i += direction) {
      const bool past = (profile[i] - background[side]) / c > 0.5;
      if (past && run_start < 0) run_start = i;
      if (!past && run_start >= 0) {
        if (std::abs(i - run_start) <= max_bump) farthest = i - direction;
        run_start = -1;
      }
    }
    if (farthest >= 0) out.protrusion_px[side] = std::fabs(farthest - edge[side]) * kStep;
  }
  return out;
}

// The clean conductor's extent against depth: extent_px = slope * f / Z + offset_px, fitted to
// the measured samples by least squares trimmed at 2.5 robust sigmas (a few rounds), and the
// robust spread of all the measured samples about it.
struct ExtentFit {
  double slope = 0, offset_px = 0, sigma_px = 0;
  double At(double f_over_z) const { return slope * f_over_z + offset_px; }
};

ExtentFit FitExtent(const std::vector<RadiusSample>& profile, double focal_px) {
  std::vector<double> x, y;
  for (const RadiusSample& s : profile) {
    if (!s.measured) continue;
    x.push_back(focal_px / s.depth_m);
    y.push_back(s.extent_px);
  }
  ExtentFit fit;
  if (x.empty()) return fit;
  std::vector<double> ratios(x.size());
  for (size_t i = 0; i < x.size(); ++i) ratios[i] = y[i] / x[i];
  fit.slope = Median(ratios);
  std::vector<double> residuals(x.size());
  auto spread = [&] {
    for (size_t i = 0; i < x.size(); ++i) residuals[i] = y[i] - fit.At(x[i]);
    const double centre = Median(residuals);
    std::vector<double> deviations(x.size());
    for (size_t i = 0; i < x.size(); ++i) deviations[i] = std::fabs(residuals[i] - centre);
    return 1.4826 * Median(deviations);
  };
  for (int round = 0; round < 5; ++round) {
    const double sigma = std::max(0.05, spread());
    double sw = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (size_t i = 0; i < x.size(); ++i) {
      if (std::fabs(residuals[i]) > 2.5 * sigma) continue;
      sw += 1;
      sx += x[i];
      sy += y[i];
      sxx += x[i] * x[i];
      sxy += x[i] * y[i];
    }
    const double det = sw * sxx - sx * sx;
    if (sw < 3 || det <= 1e-9 * sw * sxx) break;  // one depth only: keep the slope alone
    fit.slope = (sw * sxy - sx * sy) / det;
    fit.offset_px = (sy - fit.slope * sx) / sw;
  }
  fit.sigma_px = spread();
  return fit;
}

struct Stretch {
  int first = 0, last = 0;  // sample indices
};

// Runs of flagged samples: neighbouring samples (one pixel of the line's image apart, several cm
// of arc beyond ~2 m), joined across gaps of at most `gap_m` of arc.
std::vector<Stretch> Runs(const std::vector<RadiusSample>& profile,
                          const std::vector<char>& flagged, double gap_m) {
  std::vector<Stretch> runs;
  for (int i = 0; i < static_cast<int>(profile.size()); ++i) {
    if (!flagged[i]) continue;
    if (!runs.empty() && (i == runs.back().last + 1 ||
                          profile[i].arc_m - profile[runs.back().last].arc_m <= gap_m)) {
      runs.back().last = i;
    } else {
      runs.push_back({i, i});
    }
  }
  return runs;
}

// Foreign objects on the line up to max_arc_m: the obstacles the finder could not type as a
// fitting (LineObstacleType::kUnknown), on top of the line ("nest") or hanging from it ("sheet"),
// whichever way they reach farther. One the ranging chain could not measure is no fault: its
// distance is only its run's rough near end, and its pixels are as often a stray piece of the
// background as an object.
void AddForeignObjects(const LineObstacles& line, const ConductorFaultOptions& o,
                       std::vector<ConductorFault>* faults) {
  for (const LineObstacle& ob : line.obstacles) {
    if (ob.type != LineObstacleType::kUnknown || !ob.range.ok() || ob.arc_m > o.max_arc_m) {
      continue;
    }
    ConductorFault f;
    const bool hanging = ob.below_m > ob.above_m;
    f.type = hanging ? ConductorFaultType::kSheet : ConductorFaultType::kNest;
    f.arc_begin_m = ob.arc_m;
    f.arc_end_m = ob.arc_m + ob.length_m;
    f.arc_m = 0.5 * (f.arc_begin_m + f.arc_end_m);
    f.distance_m = ob.distance_m;
    f.size_m = hanging ? std::max(ob.below_m, ob.length_m)
                       : std::max({ob.above_m, ob.length_m, 2 * ob.side_m});
    f.confidence = ob.confidence;
    f.box = ob.box;
    faults->push_back(f);
  }
}

// Thin structures leaving the line at its depth (thin_attachments.h) up to max_arc_m, away from
// the obstacles on the line (a fitting's parts are at the line's depth too) and from foreign
// objects already reported: hanging ones are strings or, wider, sheets seen edge-on.
void AddThinAttachments(const cv::Mat& left_rectified, const cv::Mat& right_rectified,
                        const cv::Mat& disparity, const LineObstacles& line,
                        const StereoGeometry& g, double radius_m, const ConductorFaultOptions& o,
                        ConductorInspection* out) {
  if (out->profile.empty()) return;
  const ConductorCurve& curve = line.conductor.line;
  double tau_from = out->profile.front().tau, tau_to = tau_from;
  for (const RadiusSample& s : out->profile) {
    tau_from = std::min(tau_from, s.tau);
    tau_to = std::max(tau_to, s.tau);
  }
  // In colour where there is colour: a grey sheet on grey-green ground differs in hue.
  cv::Mat left_float, right_float;
  left_rectified.convertTo(left_float, CV_32F);
  right_rectified.convertTo(right_float, CV_32F);
  const std::vector<ThinAttachment> found = FindThinAttachments(
      left_float, right_float, disparity, curve, g, radius_m, tau_from, tau_to, o.thin);
  const size_t reported = out->faults.size();
  // Each obstacle's pixels and those next to them (2 px).
  std::vector<cv::Mat> near_obstacle(line.obstacles.size());
  for (size_t k = 0; k < line.obstacles.size(); ++k) {
    const LineObstacle& ob = line.obstacles[k];
    if (ob.mask.empty()) continue;
    cv::copyMakeBorder(ob.mask, near_obstacle[k], 2, 2, 2, 2, cv::BORDER_CONSTANT, 0);
    cv::dilate(near_obstacle[k], near_obstacle[k],
               cv::getStructuringElement(cv::MORPH_RECT, cv::Size(5, 5)));
  }
  const double margin = o.fitting_margin_m + o.margin_m;
  for (const ThinAttachment& a : found) {
    if (a.arc_m < 0 || a.arc_m > o.max_arc_m) continue;
    // A structure on an obstacle's stretch of the line, or mostly on or next to its pixels
    // (whatever disparity the sweep found for it), is a part of it (a damper's messenger, a
    // nest's twig) unless it reaches well below what the obstacle holds (a rope wrapped round
    // the line reads as a clamp, and its hanging end is too thin to be part of that body).
    bool taken = false;
    for (size_t k = 0; k < line.obstacles.size(); ++k) {
      const LineObstacle& ob = line.obstacles[k];
      bool on = a.arc_m >= ob.arc_m - margin && a.arc_m <= ob.arc_m + ob.length_m + margin;
      if (!on && !near_obstacle[k].empty()) {
        const cv::Rect around(ob.box.x - 2, ob.box.y - 2, ob.box.width + 4, ob.box.height + 4);
        const cv::Rect both = around & a.box;
        if (both.area() > 0) {
          const int overlap =
              cv::countNonZero(a.mask(both - a.box.tl()) & near_obstacle[k](both - around.tl()));
          on = overlap >= o.max_on_obstacle_share * a.pixels;
        }
      }
      taken |= on && a.length_m <= ob.below_m + o.beyond_obstacle_m;
    }
    for (size_t k = 0; k < reported; ++k) {
      const ConductorFault& f = out->faults[k];
      taken |= IsForeignObject(f.type) && a.arc_m >= f.arc_begin_m - margin &&
               a.arc_m <= f.arc_end_m + margin;
    }
    // What hangs from the line: a string or a sheet swinging up to 45 deg from straight down.
    const bool hanging = a.down_m >= std::fabs(a.side_m);
    if (taken || !hanging) continue;
    ConductorFault f;
    f.type =
        a.width_m >= o.min_sheet_width_m ? ConductorFaultType::kSheet : ConductorFaultType::kString;
    f.arc_m = a.arc_m;
    f.arc_begin_m = a.arc_begin_m;
    f.arc_end_m = a.arc_end_m;
    f.distance_m = a.distance_m;
    f.size_m = a.length_m;
    f.box = a.box;
    f.confidence = std::min(1.0, a.length_m / (2 * o.thin.min_length_m));
    out->faults.push_back(f);
  }
}

// The axis's offset from the model at `arc` (m), from samples (arcs[i], offsets[i]): the model's
// axis is off by an amount that changes along the line (it is a straight fit to a biased
// disparity), so a robust straight line through the samples, when they span at least
// kMinAxisSpanM of arc (3 rounds of least squares, dropping samples beyond 3 robust sigmas and
// 2 mm); their median otherwise. `spread`: the samples' robust sigma about it (m).
double OffsetAt(const std::vector<double>& arcs, const std::vector<double>& offsets, double arc,
                double* spread) {
  constexpr double kMinAxisSpanM = 0.2;
  const auto [lo, hi] = std::minmax_element(arcs.begin(), arcs.end());
  double a = Median(offsets), b = 0;
  auto residuals = [&] {
    std::vector<double> r;
    for (size_t i = 0; i < arcs.size(); ++i)
      r.push_back(std::fabs(offsets[i] - a - b * (arcs[i] - arc)));
    return r;
  };
  if (*hi - *lo < kMinAxisSpanM || arcs.size() < 5) {
    *spread = 1.4826 * Median(residuals());
    return a;
  }
  std::vector<char> in(arcs.size(), 1);
  for (int round = 0; round < 3; ++round) {
    double n = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (size_t i = 0; i < arcs.size(); ++i) {
      if (!in[i]) continue;
      const double x = arcs[i] - arc;
      n += 1;
      sx += x;
      sy += offsets[i];
      sxx += x * x;
      sxy += x * offsets[i];
    }
    const double det = n * sxx - sx * sx;
    if (n < 3 || det <= 1e-12) break;
    a = (sxx * sy - sx * sxy) / det;
    b = (n * sxy - sx * sy) / det;
    const std::vector<double> r = residuals();
    const double limit = std::max(0.002, 3 * 1.4826 * Median(r));
    for (size_t i = 0; i < arcs.size(); ++i) in[i] = r[i] <= limit;
  }
  *spread = 1.4826 * Median(residuals());
  return a;
}

// The state of damper `index` of `line`: the roll of its points under the line (on the matcher's
// checked map, within damper_reach_m of the axis) about the axis that the cross-sections between
// the robot and the damper placed (RadiusSample::axis), within axis_reach_m of arc before its near
// end, carried to its centre by their straight line. The near side of the line is seen larger and
// nearer than the far side, where the edges soon become too thin to place an axis (on the tuning
// sequences the far side's axes drifted by centimetres beyond 3 m). Cross-sections whose window
// reaches into the damper see its body, not the line's edges: the nearest ones are
// fitting_margin_m plus the window's half-width (margin_m and the radius) away.
FittingState CheckDamper(const LineObstacles& line, int index,
                         const std::vector<RadiusSample>& profile, const cv::Mat& disparity,
                         const CurveLocator& locator, const StereoGeometry& g, double radius_m,
                         const ConductorFaultOptions& o) {
  const LineObstacle& ob = line.obstacles[index];
  FittingState state;
  state.obstacle = index;
  state.arc_m = ob.arc_m;
  state.distance_m = ob.distance_m;
  state.roll_deg = std::numeric_limits<double>::quiet_NaN();
  const double clear = o.fitting_margin_m + o.margin_m + radius_m;
  const double begin = ob.arc_m, end = ob.arc_m + ob.length_m;
  std::vector<double> axis_arc, axis_down, axis_side;
  for (const RadiusSample& s : profile) {
    if (!s.axis_measured) continue;
    if (s.arc_m < begin - o.axis_reach_m || s.arc_m > begin - clear) continue;
    const LinePosition at = locator.Locate(s.axis);
    // An axis far along the line from its cross-section is a disparity gone astray.
    if (std::fabs(at.arc_m - s.arc_m) > kMaxAxisArcShiftM) continue;
    axis_arc.push_back(at.arc_m);
    axis_down.push_back(at.down_m);
    axis_side.push_back(at.side_m);
  }
  state.axis_samples = static_cast<int>(axis_down.size());
  if (state.axis_samples < 3) return state;
  // The model's offset changes along the line by ~1 cm per metre: cross-sections that all lie far
  // before the damper say too little about the axis at it.
  if (begin - *std::max_element(axis_arc.begin(), axis_arc.end()) > o.max_axis_gap_m) {
    state.axis_samples = 0;
    return state;
  }
  const double centre = 0.5 * (begin + end);
  double spread_down = 0, spread_side = 0;
  const double axis_down_m = OffsetAt(axis_arc, axis_down, centre, &spread_down);
  const double axis_side_m = OffsetAt(axis_arc, axis_side, centre, &spread_side);
  // Cross-sections that disagree with each other measured something else than the line's edges
  // (a defect or another object beside the line, the horizon): the axis is not known there.
  state.axis_spread_m = std::max(spread_down, spread_side);
  if (state.axis_spread_m > o.max_axis_spread_m) return state;
  std::vector<double> roll;
  for (int y = 0; y < ob.box.height; ++y) {
    const std::uint8_t* m = ob.mask.ptr<std::uint8_t>(y);
    const float* d = disparity.ptr<float>(ob.box.y + y) + ob.box.x;
    for (int x = 0; x < ob.box.width; ++x) {
      if (m[x] == 0 || !IsValidDisparity(d[x]) || d[x] + g.disparity_offset_px <= 0) continue;
      const LinePosition at =
          locator.Locate(PixelAtDepth(g, ob.box.x + x, ob.box.y + y, g.DepthFromDisparity(d[x])));
      const double down = at.down_m - axis_down_m, side = at.side_m - axis_side_m;
      // side runs along tangent x down: to the camera's -x for a line that runs away from it.
      if (down >= radius_m + o.roll_min_below_m && std::hypot(down, side) <= o.damper_reach_m) {
        roll.push_back(std::atan2(-side, down));
      }
    }
  }
  if (static_cast<int>(roll.size()) >= o.roll_min_points) {
    state.roll_deg = Median(roll) * 180.0 / std::numbers::pi;
  }
  return state;
}

// The dampers' states (InspectConductor's `fittings`) and a fault for each one turned beyond
// max_damper_roll_deg. A damper the ranging chain could not measure is not checked (its pixels are
// as often a stray piece of the background as a fitting).
void CheckDampers(const LineObstacles& line, const std::vector<RadiusSample>& profile,
                  const cv::Mat& disparity, const CurveLocator& locator, const StereoGeometry& g,
                  double radius_m, const ConductorFaultOptions& o, ConductorInspection* out) {
  for (size_t i = 0; i < line.obstacles.size(); ++i) {
    const LineObstacle& ob = line.obstacles[i];
    if (ob.type != LineObstacleType::kDamper || !ob.range.ok() || ob.arc_m > o.max_arc_m) {
      continue;
    }
    const FittingState state =
        CheckDamper(line, static_cast<int>(i), profile, disparity, locator, g, radius_m, o);
    out->fittings.push_back(state);
    if (!(std::fabs(state.roll_deg) >= o.max_damper_roll_deg)) continue;
    ConductorFault f;
    f.type = ConductorFaultType::kDamperTilted;
    f.arc_begin_m = ob.arc_m;
    f.arc_end_m = ob.arc_m + ob.length_m;
    f.arc_m = 0.5 * (f.arc_begin_m + f.arc_end_m);
    f.distance_m = ob.distance_m;
    f.roll_deg = state.roll_deg;
    f.size_m =
        (ob.below_m + radius_m) * std::sin(std::fabs(state.roll_deg) * std::numbers::pi / 180);
    f.confidence = ob.confidence;
    f.box = ob.box;
    out->faults.push_back(f);
  }
}

}  // namespace

nlohmann::json FittingState::ToJson() const {
  return {{"obstacle", obstacle},
          {"arc_m", arc_m},
          {"distance_m", distance_m},
          {"roll_deg", std::isfinite(roll_deg) ? nlohmann::json(roll_deg) : nullptr},
          {"axis_samples", axis_samples},
          {"axis_spread_m", axis_spread_m}};
}

std::string ConductorFaultTypeName(ConductorFaultType type) {
  switch (type) {
    case ConductorFaultType::kBirdcage:
      return "birdcage";
    case ConductorFaultType::kNest:
      return "nest";
    case ConductorFaultType::kSheet:
      return "sheet";
    case ConductorFaultType::kString:
      return "string";
    case ConductorFaultType::kDamperTilted:
      return "damper_tilted";
  }
  return "unknown";
}

bool IsForeignObject(ConductorFaultType type) {
  return type == ConductorFaultType::kNest || type == ConductorFaultType::kSheet ||
         type == ConductorFaultType::kString;
}

std::string InspectionStatusName(InspectionStatus status) {
  switch (status) {
    case InspectionStatus::kOk:
      return "ok";
    case InspectionStatus::kNoConductor:
      return "no_conductor";
    case InspectionStatus::kNotInspected:
      return "not_inspected";
  }
  return "unknown";
}

void ConductorFaultOptions::Check() const {
  CheckOption(max_arc_m > 0 && max_arc_m <= 50, "ConductorFaultOptions.max_arc_m", max_arc_m,
              "must be in (0, 50] m");
  CheckOption(margin_px >= 2 && margin_px <= 100, "ConductorFaultOptions.margin_px", margin_px,
              "must be in [2, 100] px");
  CheckOption(margin_m >= 0 && margin_m <= 1, "ConductorFaultOptions.margin_m", margin_m,
              "must be in [0, 1] m");
  CheckOption(max_window_px >= margin_px && max_window_px <= 200,
              "ConductorFaultOptions.max_window_px", max_window_px,
              "must be in [margin_px, 200] px");
  CheckOption(min_contrast > 0 && min_contrast < 255, "ConductorFaultOptions.min_contrast",
              min_contrast, "must be in (0, 255)");
  CheckOption(min_swelling > 0 && min_swelling < 5, "ConductorFaultOptions.min_swelling",
              min_swelling, "must be in (0, 5)");
  CheckOption(swelling_sigmas >= 0, "ConductorFaultOptions.swelling_sigmas", swelling_sigmas,
              "must be >= 0");
  CheckOption(min_swelling_length_m >= 0, "ConductorFaultOptions.min_swelling_length_m",
              min_swelling_length_m, "must be >= 0 m");
  CheckOption(merge_gap_m >= 0 && merge_gap_m < 1, "ConductorFaultOptions.merge_gap_m", merge_gap_m,
              "must be in [0, 1) m");
  CheckOption(fitting_margin_m >= 0 && fitting_margin_m < 1,
              "ConductorFaultOptions.fitting_margin_m", fitting_margin_m, "must be in [0, 1) m");
  CheckOption(fattening_px >= 0 && fattening_px <= 20, "ConductorFaultOptions.fattening_px",
              fattening_px, "must be in [0, 20] px");
  CheckOption(extent_fraction > 0 && extent_fraction < 1, "ConductorFaultOptions.extent_fraction",
              extent_fraction, "must be in (0, 1)");
  CheckOption(outlier_sigmas > 0, "ConductorFaultOptions.outlier_sigmas", outlier_sigmas,
              "must be > 0");
  CheckOption(baseline_gap_m >= 0, "ConductorFaultOptions.baseline_gap_m", baseline_gap_m,
              "must be >= 0 m");
  CheckOption(baseline_reach_m > baseline_gap_m, "ConductorFaultOptions.baseline_reach_m",
              baseline_reach_m, "must exceed baseline_gap_m");
  CheckOption(min_baseline_samples >= 1, "ConductorFaultOptions.min_baseline_samples",
              min_baseline_samples, "must be >= 1");
  CheckOption(min_swelling_samples >= 1, "ConductorFaultOptions.min_swelling_samples",
              min_swelling_samples, "must be >= 1");
  CheckOption(depth_tolerance > 0 && depth_tolerance < 1, "ConductorFaultOptions.depth_tolerance",
              depth_tolerance, "must be in (0, 1)");
  CheckOption(roll_min_below_m >= 0 && roll_min_below_m <= 1,
              "ConductorFaultOptions.roll_min_below_m", roll_min_below_m, "must be in [0, 1] m");
  CheckOption(roll_min_points >= 1, "ConductorFaultOptions.roll_min_points", roll_min_points,
              "must be >= 1");
  CheckOption(axis_reach_m > 0 && axis_reach_m <= 5, "ConductorFaultOptions.axis_reach_m",
              axis_reach_m, "must be in (0, 5] m");
  CheckOption(max_axis_gap_m > 0, "ConductorFaultOptions.max_axis_gap_m", max_axis_gap_m,
              "must be > 0 m");
  CheckOption(damper_reach_m > 0 && damper_reach_m <= 1, "ConductorFaultOptions.damper_reach_m",
              damper_reach_m, "must be in (0, 1] m");
  CheckOption(max_axis_spread_m > 0, "ConductorFaultOptions.max_axis_spread_m", max_axis_spread_m,
              "must be > 0 m");
  thin.Check();
  CheckOption(min_sheet_width_m > 0, "ConductorFaultOptions.min_sheet_width_m", min_sheet_width_m,
              "must be > 0 m");
  CheckOption(beyond_obstacle_m >= 0, "ConductorFaultOptions.beyond_obstacle_m", beyond_obstacle_m,
              "must be >= 0 m");
  CheckOption(max_on_obstacle_share > 0 && max_on_obstacle_share <= 1,
              "ConductorFaultOptions.max_on_obstacle_share", max_on_obstacle_share,
              "must be in (0, 1]");
  CheckOption(max_damper_roll_deg > 0 && max_damper_roll_deg < 90,
              "ConductorFaultOptions.max_damper_roll_deg", max_damper_roll_deg,
              "must be in (0, 90) deg");
}

nlohmann::json ConductorFault::ToJson() const {
  nlohmann::json j = {{"type", ConductorFaultTypeName(type)},
                      {"arc_m", arc_m},
                      {"arc_begin_m", arc_begin_m},
                      {"arc_end_m", arc_end_m},
                      {"distance_m", distance_m},
                      {"size_m", size_m},
                      {"confidence", confidence},
                      {"box", {box.x, box.y, box.width, box.height}}};
  if (type == ConductorFaultType::kDamperTilted) j["roll_deg"] = roll_deg;
  return j;
}

nlohmann::json ConductorInspection::ToJson(bool with_profile) const {
  nlohmann::json j = {{"status", InspectionStatusName(status)},
                      {"radius_m", radius_m},
                      {"noise_px", noise_px},
                      {"inspected_m", inspected_m},
                      {"inspected_to_m", inspected_to_m},
                      {"faults", nlohmann::json::array()}};
  if (!reason.empty()) j["reason"] = reason;
  for (const ConductorFault& f : faults) j["faults"].push_back(f.ToJson());
  j["fittings"] = nlohmann::json::array();
  for (const FittingState& s : fittings) j["fittings"].push_back(s.ToJson());
  if (with_profile) {
    nlohmann::json p = nlohmann::json::array();
    for (const RadiusSample& s : profile) {
      p.push_back({{"arc_m", s.arc_m},
                   {"pixel", {s.pixel.x, s.pixel.y}},
                   {"depth_m", s.depth_m},
                   {"measured", s.measured},
                   {"radius_measured", s.radius_measured},
                   {"radius_m", s.radius_m},
                   {"extent_m", s.extent_m},
                   {"baseline_m", s.baseline_m},
                   {"contrast", s.contrast},
                   {"axis", s.axis_measured ? nlohmann::json({s.axis.x, s.axis.y, s.axis.z})
                                            : nlohmann::json(nullptr)},
                   {"protrusion_px", {s.protrusion_px[0], s.protrusion_px[1]}}});
    }
    j["profile"] = std::move(p);
  }
  return j;
}

ConductorInspection InspectConductor(const cv::Mat& left_rectified, const cv::Mat& right_rectified,
                                     const cv::Mat& disparity, const LineObstacles& line,
                                     const StereoGeometry& g, const ConductorFaultOptions& o) {
  o.Check();
  ConductorInspection out;
  if (!line.conductor.ok()) {
    out.status = InspectionStatus::kNoConductor;
    out.reason = line.conductor.reason.empty() ? "no conductor model" : line.conductor.reason;
    return out;
  }
  if (left_rectified.empty() || right_rectified.size() != left_rectified.size() ||
      disparity.size() != left_rectified.size() || disparity.type() != CV_32FC1) {
    throw InputError(
        fmt::format("conductor inspection: the image ({}x{}) and the CV_32FC1 "
                    "disparity ({}x{}) must have the same size",
                    left_rectified.cols, left_rectified.rows, disparity.cols, disparity.rows));
  }
  const cv::Mat left = GrayFloat(left_rectified), right = GrayFloat(right_rectified);

  const ConductorCurve& curve = line.conductor.line;
  const CurveLocator locator(curve);
  const double nominal_radius = curve.radius_m > 0 ? curve.radius_m : 0.014;
  std::vector<double> profile;
  for (double tau = std::ceil(curve.tau_min); tau <= curve.tau_max; tau += 1.0) {
    const double d = curve.DisparityAt(tau);
    if (!(d > 0.5)) continue;
    const double z = g.DepthFromDisparity(d);
    const cv::Point2d p = curve.ImagePoint(tau);
    RadiusSample s;
    s.tau = tau;
    s.pixel = p;
    s.depth_m = z;
    s.arc_m = locator.Locate(PixelAtDepth(g, p.x, p.y, z)).arc_m;
    if (s.arc_m < 0 || s.arc_m > o.max_arc_m) continue;
    cv::Point2d t = curve.ImagePoint(tau + 0.5) - curve.ImagePoint(tau - 0.5);
    t *= 1.0 / std::hypot(t.x, t.y);
    cv::Point2d n(-t.y, t.x);
    if (n.y < 0) n = -n;  // side 0 = towards +v
    const double expected_px = nominal_radius * g.focal_px / z;
    const double window =
        std::min(o.max_window_px, expected_px + std::max(o.margin_px, o.margin_m * g.focal_px / z));
    const double strand_px = std::max(1.0, 0.0035 * g.focal_px / z);
    // The same cross-section in both views: the right view sees the line's point d px to the left,
    // and the line's image there runs along (u - d(tau), v), a direction of its own (the line
    // passes close beside the lenses). A strand at the line's depth protrudes alike in both views;
    // a thin far structure behind the line (a tower's member, a cable in the distance) sits
    // elsewhere in the other.
    const CrossSection l =
        MeasureCrossSection(left, p, n, expected_px, window, strand_px, o, &profile);
    const cv::Point2d right_a =
        curve.ImagePoint(tau - 0.5) - cv::Point2d(curve.DisparityAt(tau - 0.5), 0);
    const cv::Point2d right_b =
        curve.ImagePoint(tau + 0.5) - cv::Point2d(curve.DisparityAt(tau + 0.5), 0);
    cv::Point2d tr = right_b - right_a;
    tr *= 1.0 / std::max(1e-9, std::hypot(tr.x, tr.y));
    cv::Point2d nr(-tr.y, tr.x);
    if (nr.y < 0) nr = -nr;
    const CrossSection r = MeasureCrossSection(right, p - cv::Point2d(d, 0), nr, expected_px,
                                               window, strand_px, o, &profile);
    s.contrast = std::min(l.contrast, r.contrast);
    // The band between the expected edges and the measured extent must be at the line's depth
    // where the matcher measured it: where the line crosses the horizon or passes in front of
    // another surface, the extent can lie on that surface's edge instead.
    const double tolerance = std::max(1.0, o.depth_tolerance * d);
    bool band_at_line = true;
    for (int side = 0; side < 2 && l.extent_found && band_at_line; ++side) {
      const double sign = side == 0 ? 1.0 : -1.0;
      for (double off = expected_px + o.fattening_px; off < l.extent_px[side] - 1.0; off += 1.0) {
        const float v = DisparityNear(disparity, p.x + sign * off * n.x, p.y + sign * off * n.y);
        if (std::isfinite(v) && std::fabs(v - d) > tolerance) {
          band_at_line = false;
          break;
        }
      }
    }
    const double agreement = std::max(1.0, 0.15 * expected_px);
    if (l.measured && r.measured && std::fabs(l.radius_px - r.radius_px) <= agreement) {
      // The middle of the band in each view is the axis's image; the right view's lies on the
      // row of the left's at the axis's disparity d + dd, where the two middles' offsets along
      // their normals agree (a band along the rows says nothing about its disparity).
      // The model's disparity may be off by several pixels (see RadiusSample::axis): the right
      // view is measured again where the first estimate puts the band, until it moves < 0.1 px.
      const double mid_l = 0.5 * (l.edge_px[0] - l.edge_px[1]);
      double mid_r = 0.5 * (r.edge_px[0] - r.edge_px[1]);
      if (std::fabs(nr.x) >= kMinNormalX) {
        double axis_d = d;
        bool found = true;
        for (int round = 0; round < kAxisRounds && found; ++round) {
          const double step = (mid_l * n.dot(nr) - mid_r) / nr.x;
          axis_d += step;
          if (std::fabs(step) < 0.1 || !(axis_d + g.disparity_offset_px > 0.5)) break;
          const CrossSection again = MeasureCrossSection(
              right, p - cv::Point2d(axis_d, 0), nr, expected_px, window, strand_px, o, &profile);
          found = again.measured && std::fabs(l.radius_px - again.radius_px) <= agreement;
          mid_r = 0.5 * (again.edge_px[0] - again.edge_px[1]);
        }
        const cv::Point2d q = p + mid_l * n;
        if (found && axis_d + g.disparity_offset_px > 0.5) {
          s.axis_measured = true;
          s.axis = PixelAtDepth(g, q.x, q.y, g.DepthFromDisparity(axis_d));
        }
      }
    }
    // Both views must agree on the extent: an edge pulled by the background (the horizon, a
    // structure behind the line, the ground's texture) lies elsewhere in the other view, while the
    // conductor's outline, swollen or not, is at the line's depth in both.
    auto width = [](const double* e) { return e[0] + e[1]; };
    if (l.extent_found && r.extent_found && band_at_line &&
        std::fabs(width(l.extent_px) - width(r.extent_px)) <= 2 * agreement) {
      s.measured = true;
      s.extent_px = 0.25 * (width(l.extent_px) + width(r.extent_px));
      s.extent_m = s.extent_px * z / g.focal_px;
      // The half-way crossings give the conductor's radius where both views agree on them.
      if (l.measured && r.measured && std::fabs(l.radius_px - r.radius_px) <= agreement) {
        s.radius_measured = true;
        s.radius_px = 0.5 * (l.radius_px + r.radius_px);
        s.radius_m = s.radius_px * z / g.focal_px;
        for (int side = 0; side < 2; ++side) {
          const double a = l.protrusion_px[side], b = r.protrusion_px[side];
          if (a > 0 && b > 0 && std::fabs(a - b) <= std::max(1.5, 0.25 * std::max(a, b))) {
            s.protrusion_px[side] = std::min(a, b);
          }
        }
      }
    }
    out.profile.push_back(s);
  }

  // Cross-sections through an obstacle on the line (a fitting, or a body the finder could not
  // type) measure the obstacle, not the conductor: they are not measured samples.
  for (RadiusSample& s : out.profile) {
    for (const LineObstacle& ob : line.obstacles) {
      const double margin = o.fitting_margin_m + o.margin_m;
      if (s.arc_m >= ob.arc_m - margin && s.arc_m <= ob.arc_m + ob.length_m + margin) {
        s.measured = false;
        s.radius_measured = false;
        s.axis_measured = false;
      }
    }
  }

  // The conductor's radius from the half-way crossings; the extents' noise against the clean
  // conductor's own extent nearby.
  int measured_count = 0;
  std::vector<double> radii;
  for (const RadiusSample& s : out.profile) {
    measured_count += s.measured ? 1 : 0;
    if (s.radius_measured) radii.push_back(s.radius_m);
  }
  if (measured_count < 20 || radii.empty()) {
    out.status = InspectionStatus::kNotInspected;
    out.reason = fmt::format(
        "only {} samples of the line could be measured (too little contrast "
        "against the background)",
        measured_count);
    AddForeignObjects(line, o, &out.faults);
    AddThinAttachments(left_rectified, right_rectified, disparity, line, g, nominal_radius, o,
                       &out);
    CheckDampers(line, out.profile, disparity, locator, g, nominal_radius, o, &out);
    return out;
  }
  out.radius_m = Median(radii);
  // The clean conductor's extent. Over the whole line, its image half-width is its radius times
  // f / Z plus an offset in pixels that does not scale with depth (the blur, the lit side's
  // lighter strands): a robust fit of extent_px = a f / Z + b; its residuals' robust spread is the
  // noise. Samples off the fit by more than outlier_sigmas are not a reference (a rope measured
  // instead of the line, the line half hidden, a swelling). At each sample, the reference is the
  // median over the inlier samples between baseline_gap_m and baseline_reach_m of arc on either
  // side (the background and the lighting change along the line; a swelling up to twice the gap
  // long is not its own reference), or the fit where there are too few.
  const int n = static_cast<int>(out.profile.size());
  const ExtentFit fit = FitExtent(out.profile, g.focal_px);
  out.noise_px = std::max(0.05, fit.sigma_px);
  std::vector<char> inlier(n, 0);
  for (int i = 0; i < n; ++i) {
    const RadiusSample& s = out.profile[i];
    inlier[i] = s.measured && std::fabs(s.extent_px - fit.At(g.focal_px / s.depth_m)) <=
                                  o.outlier_sigmas * out.noise_px;
  }
  std::vector<double> near;
  for (int i = 0; i < n; ++i) {
    RadiusSample& s = out.profile[i];
    near.clear();
    for (int j = 0; j < n; ++j) {
      const RadiusSample& t = out.profile[j];
      const double gap = std::fabs(t.arc_m - s.arc_m);
      if (inlier[j] && gap >= o.baseline_gap_m && gap <= o.baseline_reach_m) {
        // Its radius term, carried to this sample's depth.
        near.push_back((t.extent_px - fit.offset_px) * t.depth_m);
      }
    }
    const double scale = g.focal_px / s.depth_m;
    const bool enough = static_cast<int>(near.size()) >= o.min_baseline_samples;
    const double reference_px = enough ? Median(near) / s.depth_m + fit.offset_px : fit.At(scale);
    s.baseline_m = reference_px / scale;
  }
  for (size_t i = 0; i < out.profile.size(); ++i) {
    const RadiusSample& s = out.profile[i];
    if (!s.measured) continue;
    out.inspected_to_m = std::max(out.inspected_to_m, s.arc_m);
    if (i > 0 && out.profile[i - 1].measured) {
      out.inspected_m += std::fabs(s.arc_m - out.profile[i - 1].arc_m);
    }
  }
  out.status = InspectionStatus::kOk;

  // Stretches that belong to an obstacle on the line, a fitting or a foreign object: within the
  // margin of it, plus the sampled window's half-width in metres (a cross-section that reaches into
  // the obstacle's image sees it).
  auto on_obstacle = [&](const ConductorFault& f) {
    const double window_m =
        std::min(o.max_window_px * f.distance_m / g.focal_px,
                 out.radius_m + std::max(o.margin_px * f.distance_m / g.focal_px, o.margin_m));
    const double margin = o.fitting_margin_m + window_m;
    for (const LineObstacle& ob : line.obstacles) {
      if (f.arc_end_m >= ob.arc_m - margin && f.arc_begin_m <= ob.arc_m + ob.length_m + margin) {
        return true;
      }
    }
    return false;
  };
  auto make_fault = [&](ConductorFaultType type, const Stretch& r) {
    ConductorFault f;
    f.type = type;
    f.arc_begin_m = out.profile[r.first].arc_m;
    f.arc_end_m = out.profile[r.last].arc_m;
    if (f.arc_begin_m > f.arc_end_m) std::swap(f.arc_begin_m, f.arc_end_m);
    f.arc_m = 0.5 * (f.arc_begin_m + f.arc_end_m);
    double depth = 0;
    int measured = 0;
    cv::Rect box;
    for (int i = r.first; i <= r.last; ++i) {
      const RadiusSample& s = out.profile[i];
      depth += s.depth_m;
      measured += s.measured ? 1 : 0;
      const cv::Point2d p = curve.ImagePoint(s.tau);
      const double w = nominal_radius * g.focal_px / s.depth_m +
                       std::max(o.margin_px, o.margin_m * g.focal_px / s.depth_m);
      const cv::Rect around(
          cv::Point(static_cast<int>(p.x - w), static_cast<int>(p.y - w)),
          cv::Point(static_cast<int>(p.x + w) + 1, static_cast<int>(p.y + w) + 1));
      box = box.empty() ? around : (box | around);
    }
    f.distance_m = depth / (r.last - r.first + 1);
    f.box = box & cv::Rect(0, 0, left.cols, left.rows);
    f.confidence = static_cast<double>(measured) / (r.last - r.first + 1);
    return f;
  };

  // Swelling: the extent beyond the clean conductor's by the noise, and its radius term (the
  // extent less the offset) by a share.
  std::vector<char> swollen(n, 0);
  std::vector<double> increase_m(n, 0.0);
  for (int i = 0; i < n; ++i) {
    const RadiusSample& s = out.profile[i];
    if (!s.measured) continue;
    const double scale = g.focal_px / s.depth_m;
    const double reference_px = s.baseline_m * scale;
    const double radius_px = reference_px - fit.offset_px;
    if (radius_px <= 0) continue;
    const double excess_px = s.extent_px - reference_px;
    increase_m[i] = excess_px / scale;
    swollen[i] =
        excess_px > o.min_swelling * radius_px && excess_px > o.swelling_sigmas * out.noise_px;
  }
  // Arc covered by a stretch: its samples' arcs plus half the step to the neighbour beyond each end
  // (beyond ~2 m the line runs nearly along the view and one pixel of its image spans several
  // centimetres of arc).
  auto half_step = [&](int i, int neighbour) {
    if (neighbour < 0 || neighbour >= n) neighbour = 2 * i - neighbour;
    if (neighbour < 0 || neighbour >= n) return 0.0;
    return 0.5 * std::fabs(out.profile[i].arc_m - out.profile[neighbour].arc_m);
  };
  for (const Stretch& r : Runs(out.profile, swollen, o.merge_gap_m)) {
    ConductorFault f = make_fault(ConductorFaultType::kBirdcage, r);
    int count = 0;
    for (int i = r.first; i <= r.last; ++i) count += swollen[i];
    const double covered = f.arc_end_m - f.arc_begin_m + half_step(r.first, r.first - 1) +
                           half_step(r.last, r.last + 1);
    if (covered < o.min_swelling_length_m || count < o.min_swelling_samples) continue;
    if (on_obstacle(f)) continue;
    double largest = 0;
    for (int i = r.first; i <= r.last; ++i) {
      if (swollen[i]) {
        largest = std::max(largest, increase_m[i]);
      }
    }
    f.size_m = largest;
    out.faults.push_back(f);
  }
  AddForeignObjects(line, o, &out.faults);
  AddThinAttachments(left_rectified, right_rectified, disparity, line, g, out.radius_m, o, &out);
  CheckDampers(line, out.profile, disparity, locator, g, out.radius_m, o, &out);

  std::sort(out.faults.begin(), out.faults.end(),
            [](const ConductorFault& a, const ConductorFault& b) {
              return a.arc_begin_m < b.arc_begin_m;
            });
  return out;
}

}  // namespace linesight
