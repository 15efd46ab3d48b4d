#include "linesight/line/line_obstacles.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "linesight/core/disparity.h"
#include "linesight/core/error.h"
#include "linesight/line/line_quantile.h"
#include "linesight/ranging/thin_structures.h"
#include "linesight/stereo/matcher.h"

namespace linesight {

namespace {

// A body pixel placed relative to the conductor.
struct LinePoint {
  int x, y;
  float d;
  double z, arc, offset, down, side;
};

// How far beyond the observed ends of the conductor's image an obstacle may touch it (px): the
// obstacle itself hides the conductor behind it.
constexpr double kHiddenLinePx = 40.0;

const cv::Mat& LineDisparity(const RangingPipeline& pipeline, const RangingFrame& frame,
                             const LineObstacleOptions& options) {
  return options.dense_disparity ? frame.disparity : pipeline.RangingDisparity(frame);
}

// The map with its speckles invalid (cv::filterSpeckles on the 1/16 px fixed-point map).
cv::Mat Despeckle(const cv::Mat& disparity, const LineObstacleOptions& o) {
  if (o.speckle_window_px == 0) return disparity.clone();
  constexpr std::int16_t kInvalid = std::numeric_limits<std::int16_t>::min();
  cv::Mat fixed(disparity.size(), CV_16SC1);
  for (int y = 0; y < disparity.rows; ++y) {
    const float* d = disparity.ptr<float>(y);
    std::int16_t* f = fixed.ptr<std::int16_t>(y);
    for (int x = 0; x < disparity.cols; ++x) {
      if (!IsValidDisparity(d[x])) {
        f[x] = kInvalid;
        continue;
      }
      // std::lround (halves away from zero) of the clamped value, without the library call.
      const double v = std::clamp(double(d[x]) * 16.0, -40000.0, 40000.0);
      const auto rounded = v >= 0 ? std::int64_t(v + 0.5) : -std::int64_t(-v + 0.5);
      f[x] = cv::saturate_cast<std::int16_t>(rounded);
    }
  }
  cv::filterSpeckles(fixed, kInvalid, o.speckle_window_px,
                     static_cast<double>(std::lround(o.speckle_range_px * 16.0)));
  cv::Mat out = disparity.clone();
  out.setTo(std::numeric_limits<float>::infinity(), fixed == kInvalid);
  return out;
}

using line_detail::Quantile;

cv::Point3d BackProjectAt(const StereoGeometry& g, double u, double v, double z) {
  return {(u - g.cx) * z / g.focal_px, (v - g.cy) * z / g.focal_px, z};
}

std::vector<LinePoint> CorridorPoints(const cv::Mat& disparity, const cv::Mat& bodies,
                                      const StereoGeometry& g, const ConductorModel& model,
                                      const LineObstacleOptions& o) {
  std::vector<LinePoint> points;
  const CurveLocator locator(model.line);
  for (int y = 0; y < disparity.rows; ++y) {
    const float* d = disparity.ptr<float>(y);
    const std::uint8_t* b = bodies.ptr<std::uint8_t>(y);
    for (int x = 0; x < disparity.cols; ++x) {
      if (b[x] == 0 || !IsValidDisparity(d[x]) || d[x] + g.disparity_offset_px <= 0) continue;
      const double z = g.DepthFromDisparity(d[x]);
      const LinePosition at = locator.Locate(BackProjectAt(g, x, y, z));
      if (std::fabs(at.side_m) > o.corridor_side_m || at.down_m < -o.corridor_above_m ||
          at.down_m > o.corridor_below_m || at.arc_m < -0.5 || at.arc_m > o.max_arc_m) {
        continue;
      }
      points.push_back({x, y, d[x], z, at.arc_m, at.offset_m, at.down_m, at.side_m});
    }
  }
  return points;
}

// Image bounds of the corridor's points at given depths, for the body test to work only there: the
// corridor holds the points within `reach` of the axis between the arcs looked at (a point's
// offset from its foot on the axis is its down and side offsets, more by a bend's along-axis part,
// which the margin on `reach` covers).
class CorridorBounds {
 public:
  CorridorBounds(const ConductorCurve& line, const StereoGeometry& g, const LineObstacleOptions& o)
      : g_(g),
        reach_(1.1 *
                   std::hypot(o.corridor_side_m, std::max(o.corridor_above_m, o.corridor_below_m)) +
               0.05) {
    constexpr double kAxisStep = 0.1;  // m along the axis
    for (double a = -0.5; a < o.max_arc_m + kAxisStep; a += kAxisStep)
      axis_.push_back(AxisAt(line, a));
  }

  // Bounds of the corridor's pixels with disparities in [d_from, d_to] (disparity map
  // coordinates; may reach beyond the image).
  cv::Rect operator()(double d_from, double d_to) const {
    const double z_near = g_.DepthFromDisparity(d_to) * (1 - 1e-6);
    const double z_far = d_from + g_.disparity_offset_px > 0
                             ? g_.DepthFromDisparity(d_from) * (1 + 1e-6)
                             : std::numeric_limits<double>::infinity();
    double u0 = std::numeric_limits<double>::infinity(), v0 = u0, u1 = -u0, v1 = -u0;
    for (size_t i = 1; i < axis_.size(); ++i) {
      const cv::Point3d& a = axis_[i - 1];
      const cv::Point3d& b = axis_[i];
      const double z_lo = std::max({z_near, std::min(a.z, b.z) - reach_, 1e-3});
      const double z_hi = std::min(z_far, std::max(a.z, b.z) + reach_);
      if (z_lo > z_hi) continue;
      // Over a box with z > 0 the projection is extreme at its corners.
      for (const double x : {std::min(a.x, b.x) - reach_, std::max(a.x, b.x) + reach_}) {
        for (const double y : {std::min(a.y, b.y) - reach_, std::max(a.y, b.y) + reach_}) {
          for (const double z : {z_lo, z_hi}) {
            const double u = g_.focal_px * x / z + g_.cx, v = g_.focal_px * y / z + g_.cy;
            u0 = std::min(u0, u);
            u1 = std::max(u1, u);
            v0 = std::min(v0, v);
            v1 = std::max(v1, v);
          }
        }
      }
    }
    if (!(u0 <= u1)) return {};
    constexpr double kLimit = 1e6;  // px: far beyond any image
    const int x0 = int(std::floor(std::max(u0, -kLimit))) - 2;
    const int y0 = int(std::floor(std::max(v0, -kLimit))) - 2;
    const int x1 = int(std::ceil(std::min(u1, kLimit))) + 3;
    const int y1 = int(std::ceil(std::min(v1, kLimit))) + 3;
    return {cv::Point(x0, y0), cv::Point(x1, y1)};
  }

 private:
  // The axis at arc a: the polyline, extended straight beyond its ends (as CurveLocator does).
  static cv::Point3d AxisAt(const ConductorCurve& line, double a) {
    const std::vector<cv::Point3d>& p = line.points;
    const std::vector<double>& s = line.arcs;
    if (p.size() < 2) return p.empty() ? cv::Point3d() : p[0];
    size_t i = size_t(std::upper_bound(s.begin(), s.end(), a) - s.begin());
    i = std::clamp<size_t>(i, 1, p.size() - 1);
    const double length = s[i] - s[i - 1];
    if (length <= 1e-9) return p[i - 1];
    return p[i - 1] + (a - s[i - 1]) / length * (p[i] - p[i - 1]);
  }

  const StereoGeometry& g_;
  double reach_;
  std::vector<cv::Point3d> axis_;
};

// Runs of points (sorted by arc) separated by gaps longer than cluster_gap_m.
std::vector<std::vector<LinePoint>> SplitAlongLine(std::vector<LinePoint> points, double gap_m) {
  std::sort(points.begin(), points.end(),
            [](const LinePoint& a, const LinePoint& b) { return a.arc < b.arc; });
  std::vector<std::vector<LinePoint>> runs;
  for (size_t i = 0; i < points.size(); ++i) {
    if (i == 0 || points[i].arc - points[i - 1].arc > gap_m) runs.emplace_back();
    runs.back().push_back(points[i]);
  }
  return runs;
}

// `radius_m`: the conductor's.
LineObstacleType Classify(const LineObstacle& o, const LineObstacleOptions& opt, double radius_m) {
  // A string of discs rising above the line.
  if (o.above_m >= opt.insulator_min_above_m) return LineObstacleType::kInsulator;
  // What no fitting is: a mass on top of the line that spreads to its sides, or something hanging
  // deeper than a damper's weights.
  const double outline_m2 = 2 * o.top_side_m * (o.above_m + radius_m);
  if ((o.above_m >= opt.foreign_min_above_m && o.top_side_m >= opt.foreign_min_side_m &&
       o.area_m2 >= opt.foreign_min_fill * outline_m2) ||
      o.below_m >= opt.foreign_min_below_m) {
    return LineObstacleType::kUnknown;
  }
  // The discs of a string whose top is out of view reach wide to the sides.
  if (o.side_m >= opt.insulator_min_side_m) return LineObstacleType::kInsulator;
  if (o.below_m >= opt.damper_min_below_m) return LineObstacleType::kDamper;
  return LineObstacleType::kClamp;
}

// Whether a point lies on the conductor's image band (its half-width plus the fattening and a
// margin) at a disparity near the conductor's there. Judged in the image, where the axis is known
// to a pixel or two, rather than in 3D, where its depth error far away exceeds an obstacle's size.
bool OnTheLine(const LinePoint& p, const ConductorModel& model, const StereoGeometry& g,
               const LineObstacleOptions& o) {
  const ConductorCurve& line = model.line;
  const double r = line.radius_m > 0 ? line.radius_m : o.conductor.max_radius_m;
  double tau = 0, lateral = 0;
  line.ImageCoordinates(p.x, p.y, &tau, &lateral);
  // Beyond the observed ends too: an obstacle hides the conductor behind it.
  if (tau < line.tau_min - kHiddenLinePx || tau > line.tau_max + kHiddenLinePx) return false;
  const double half_width = r * (p.d + g.disparity_offset_px) / g.baseline_m +
                            o.conductor.fattening_px + o.attach_margin_px;
  const double d_line = line.DisparityAt(tau);
  if (std::fabs(lateral) > half_width) return false;
  return std::fabs(p.d - d_line) <= 1.0 ||
         (d_line + g.disparity_offset_px > 0 &&
          std::fabs(p.z - g.DepthFromDisparity(d_line)) <= o.attach_depth_m);
}

// Extent of a piece in the conductor's frame: 5th..95th percentile along, below and beside the
// line.
struct PieceExtent {
  double lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
  // Gap between two extents as boxes (0 when they overlap), m.
  double GapTo(const PieceExtent& e) const {
    double sum = 0;
    for (int k = 0; k < 3; ++k) {
      const double gap = std::max({0.0, e.lo[k] - hi[k], lo[k] - e.hi[k]});
      sum += gap * gap;
    }
    return std::sqrt(sum);
  }
};

// The extent of a non-empty set of points.
PieceExtent ExtentOf(const std::vector<LinePoint>& points) {
  std::array<std::vector<double>, 3> c;
  for (const LinePoint& p : points) {
    c[0].push_back(p.arc);
    c[1].push_back(p.down);
    c[2].push_back(p.side);
  }
  PieceExtent e;
  for (size_t k = 0; k < 3; ++k) {
    e.lo[k] = Quantile(c[k], 0.05);
    e.hi[k] = Quantile(c[k], 0.95);
  }
  return e;
}

// Marks, in `keep`, every piece whose extent comes within `gap_m` of the conductor's cross-section
// (radius_m around the axis) or of a kept piece's, repeatedly (a chain of pieces hanging from one
// another joins too). Label 0 is the background. Returns the number of pieces joined to the
// conductor directly.
int JoinThinlyLinkedPieces(const std::vector<LinePoint>& run, const std::vector<int>& label,
                           double gap_m, double radius_m, std::vector<bool>* keep) {
  if (gap_m <= 0) return 0;
  const size_t count = keep->size();
  std::vector<std::vector<LinePoint>> pieces(count);
  for (size_t i = 0; i < run.size(); ++i) pieces[size_t(label[i])].push_back(run[i]);
  std::vector<PieceExtent> extent(count);
  for (size_t l = 1; l < count; ++l) {
    if (!pieces[l].empty()) extent[l] = ExtentOf(pieces[l]);
  }
  // The conductor itself: a fitting's grip on it may be too thin to be a body (a damper's clamp is
  // 44 mm across a 28 mm conductor), so its hanging parts join the line directly.
  PieceExtent line;
  line.lo[0] = -std::numeric_limits<double>::infinity();
  line.hi[0] = std::numeric_limits<double>::infinity();
  line.lo[1] = line.lo[2] = -radius_m;
  line.hi[1] = line.hi[2] = radius_m;
  int joined_to_line = 0;
  for (size_t l = 1; l < count; ++l) {
    if ((*keep)[l] || pieces[l].empty() || extent[l].GapTo(line) > gap_m) continue;
    (*keep)[l] = true;
    ++joined_to_line;
  }
  for (bool grew = true; grew;) {
    grew = false;
    for (size_t l = 1; l < count; ++l) {
      if ((*keep)[l] || pieces[l].empty()) continue;
      for (size_t k = 1; k < count; ++k) {
        if ((*keep)[k] && extent[l].GapTo(extent[k]) <= gap_m) {
          (*keep)[l] = grew = true;
          break;
        }
      }
    }
  }
  return joined_to_line;
}

// The points of a run that belong to an obstacle of this line: the run's 8-connected pieces in the
// image (1 px gaps closed) that touch the conductor with at least min_attached_pixels points. A
// piece of the tower or of a mismatched background that shares the run's stretch of line but is
// not joined to the conductor is left out, so it neither makes an obstacle nor changes one's
// shape. *attached counts the kept points on the line, and min_attached_pixels for each piece
// joined to the conductor without touching it.
std::vector<LinePoint> AttachedPieces(const std::vector<LinePoint>& run,
                                      const ConductorModel& model, const StereoGeometry& g,
                                      const LineObstacleOptions& o, int* attached) {
  *attached = 0;
  int x0 = run[0].x, x1 = run[0].x, y0 = run[0].y, y1 = run[0].y;
  for (const LinePoint& p : run) {
    x0 = std::min(x0, p.x);
    x1 = std::max(x1, p.x);
    y0 = std::min(y0, p.y);
    y1 = std::max(y1, p.y);
  }
  cv::Mat mask = cv::Mat::zeros(y1 - y0 + 3, x1 - x0 + 3, CV_8UC1);
  for (const LinePoint& p : run) mask.at<std::uint8_t>(p.y - y0 + 1, p.x - x0 + 1) = 255;
  cv::Mat closed, labels;
  cv::morphologyEx(mask, closed, cv::MORPH_CLOSE,
                   cv::getStructuringElement(cv::MORPH_RECT, cv::Size(3, 3)));
  const int count = cv::connectedComponents(closed, labels, 8, CV_32S);
  std::vector<int> label(run.size()), on_line(count, 0);
  for (size_t i = 0; i < run.size(); ++i) {
    label[i] = labels.at<int>(run[i].y - y0 + 1, run[i].x - x0 + 1);
    on_line[label[i]] += OnTheLine(run[i], model, g, o);
  }
  std::vector<bool> keep(size_t(count), false);
  for (int l = 1; l < count; ++l) keep[size_t(l)] = on_line[l] >= o.min_attached_pixels;
  const int joined_to_line = JoinThinlyLinkedPieces(
      run, label, o.join_gap_m,
      model.line.radius_m > 0 ? model.line.radius_m : o.conductor.max_radius_m, &keep);
  std::vector<LinePoint> kept;
  for (size_t i = 0; i < run.size(); ++i) {
    if (keep[size_t(label[i])]) kept.push_back(run[i]);
  }
  for (int l = 1; l < count; ++l) *attached += on_line[l] >= o.min_attached_pixels ? on_line[l] : 0;
  *attached += joined_to_line * o.min_attached_pixels;
  return kept;
}

// The parts of runs that belong to an obstacle of this line (AttachedPieces), with neighbouring
// runs joined when their extents in the conductor's frame come within o.join_runs_gap_m of each
// other (see there).
std::vector<std::vector<LinePoint>> JoinCloseRuns(std::vector<std::vector<LinePoint>> runs,
                                                  const ConductorModel& model,
                                                  const StereoGeometry& g,
                                                  const LineObstacleOptions& o) {
  std::vector<std::vector<LinePoint>> joined;
  PieceExtent last;
  for (std::vector<LinePoint>& run : runs) {
    if (static_cast<int>(run.size()) < o.min_pixels) continue;
    int attached = 0;
    std::vector<LinePoint> kept = AttachedPieces(run, model, g, o, &attached);
    if (kept.empty() || attached < o.min_attached_pixels) continue;
    const PieceExtent e = ExtentOf(kept);
    if (!joined.empty() && o.join_runs_gap_m > 0 && last.GapTo(e) <= o.join_runs_gap_m) {
      joined.back().insert(joined.back().end(), kept.begin(), kept.end());
      last = ExtentOf(joined.back());
    } else {
      joined.push_back(std::move(kept));
      last = e;
    }
  }
  return joined;
}

// Shape, box and mask of one run; false when it is not an obstacle of this line.
bool Describe(const std::vector<LinePoint>& all, const ConductorModel& model,
              const StereoGeometry& g, const LineObstacleOptions& o, LineObstacle* out) {
  if (static_cast<int>(all.size()) < o.min_pixels) return false;
  int attached = 0;
  const std::vector<LinePoint> run = AttachedPieces(all, model, g, o, &attached);
  if (static_cast<int>(run.size()) < o.min_pixels) return false;
  double area = 0;
  for (const LinePoint& p : run) area += (p.z / g.focal_px) * (p.z / g.focal_px);
  if (area < o.min_area_m2) return false;
  std::vector<double> z, arc, down, up, side, top_side;
  int x0 = run[0].x, x1 = run[0].x, y0 = run[0].y, y1 = run[0].y;
  for (const LinePoint& p : run) {
    z.push_back(p.z);
    arc.push_back(p.arc);
    down.push_back(p.down);
    up.push_back(-p.down);
    side.push_back(std::fabs(p.side));
    if (p.down < 0 && p.down >= -o.foreign_top_band_m) top_side.push_back(std::fabs(p.side));
    x0 = std::min(x0, p.x);
    x1 = std::max(x1, p.x);
    y0 = std::min(y0, p.y);
    y1 = std::max(y1, p.y);
  }
  const double fat = o.conductor.fattening_px * Quantile(z, 0.5) / g.focal_px;
  if (attached < o.min_attached_pixels) return false;
  out->pixels = static_cast<int>(run.size());
  out->area_m2 = area;
  out->length_m = std::max(0.0, Quantile(arc, 0.97) - Quantile(arc, 0.03));
  out->above_m = std::max(0.0, Quantile(up, 0.97) - fat);
  out->below_m = std::max(0.0, Quantile(down, 0.97) - fat);
  out->side_m = std::max(0.0, Quantile(side, 0.97) - fat);
  out->top_side_m = top_side.empty() ? 0.0 : std::max(0.0, Quantile(top_side, 0.97) - fat);
  out->box = cv::Rect(x0, y0, x1 - x0 + 1, y1 - y0 + 1);
  out->type =
      Classify(*out, o, model.line.radius_m > 0 ? model.line.radius_m : o.conductor.max_radius_m);
  out->mask = cv::Mat::zeros(out->box.size(), CV_8UC1);
  for (const LinePoint& p : run) out->mask.at<std::uint8_t>(p.y - y0, p.x - x0) = 255;
  out->confidence = std::min(1.0, run.size() / (4.0 * o.min_pixels)) *
                    std::min(1.0, attached / (2.0 * o.min_attached_pixels));
  // Until ranged: the run's own near end.
  out->arc_m = Quantile(arc, 0.03);
  out->distance_m = Quantile(z, 0.03);
  return true;
}

// How far the model's disparity may be from a pixel's for that pixel to be taken as the band's
// own (the model's d(tau) is least sure beyond the observed ends of the line, where a far obstacle
// hides the conductor behind it).
constexpr double kBandModelTolerance = 0.25;
// Pixels on one surface across the band: log disparities within 0.06 (depths within +-6 %).
constexpr double kSurfaceLogTolerance = 0.06;

// The conductor's image band where it is wider than the conductor (CV_8U, 255 on the band's
// pixels there): far obstacles on the line that are too small to be bodies. Only where the
// conductor's image radius is below the matcher's fattening (beyond ~2.5 m for a 28 mm conductor
// and a 4 px fattening): nearer, an obstacle wider than the conductor is a body. At every pixel
// of the line's image arc, the band is the run of pixels across the line (gaps up to 2 px) on the
// surface of the pixel nearest the axis whose disparity agrees with the model's; its width is the
// conductor's image diameter 2 r (d + doffs) / B plus the fattening on both sides, measured as the
// median excess over all such sections of the line. A section is widened when its excess over
// that exceeds min_widening_px and min_widening_relative of the conductor's band width; a run of
// at least min_widening_length_px widened sections (one-section gaps bridged) marks its pixels.
// A 52 mm clamp 4.5 m ahead is 8 px wide, hardly a 45 mm body, but widens the band by 4-10 px.
cv::Mat WideningOfTheLine(const cv::Mat& disparity, const ConductorModel& model,
                          const StereoGeometry& g, const LineObstacleOptions& o) {
  cv::Mat out = cv::Mat::zeros(disparity.size(), CV_8UC1);
  if (o.min_widening_px <= 0) return out;
  const ConductorCurve& line = model.line;
  const double r = line.radius_m > 0 ? line.radius_m : o.conductor.max_radius_m;
  const cv::Rect image(0, 0, disparity.cols, disparity.rows);
  const auto pixel_at = [&](const cv::Point2d& c, double across, double along) {
    return cv::Point(int(std::lround(c.x + across * line.normal.x + along * line.axis.x)),
                     int(std::lround(c.y + across * line.normal.y + along * line.axis.y)));
  };
  const auto on_surface = [&](const cv::Point& p, double d_ref) {
    if (!image.contains(p)) return false;
    const float d = disparity.at<float>(p);
    return IsValidDisparity(d) && d + g.disparity_offset_px > 0 &&
           std::fabs(std::log((d + g.disparity_offset_px) / (d_ref + g.disparity_offset_px))) <=
               kSurfaceLogTolerance;
  };
  struct Section {
    double tau, conductor_px, d_ref;
    int lo, hi;  // the band across the line (px along the normal from the axis)
  };
  std::vector<Section> sections;
  for (double tau = std::floor(line.tau_min - kHiddenLinePx); tau <= line.tau_max + kHiddenLinePx;
       tau += 1.0) {
    const double d_line = line.DisparityAt(tau);
    if (d_line + g.disparity_offset_px <= 0 ||
        g.DepthFromDisparity(d_line) > o.conductor.max_depth_m) {
      continue;
    }
    const double conductor_px = r * (d_line + g.disparity_offset_px) / g.baseline_m;
    if (conductor_px >= o.conductor.fattening_px) continue;
    const cv::Point2d c = line.ImagePoint(tau);
    const int half = int(std::ceil(conductor_px + o.conductor.fattening_px));
    Section sec{tau, conductor_px, -1, 0, 0};
    for (int k = 0; k <= half && sec.d_ref < 0; ++k) {
      for (int across : {k, -k}) {
        const cv::Point p = pixel_at(c, across, 0);
        if (!image.contains(p)) continue;
        const float d = disparity.at<float>(p);
        if (IsValidDisparity(d) && std::fabs(d - d_line) <= kBandModelTolerance * d_line) {
          sec = {tau, conductor_px, d, across, across};
          break;
        }
      }
    }
    if (sec.d_ref < 0) continue;
    // Out to the corridor's depth below or above the line.
    const int reach = int(std::max(o.corridor_above_m, o.corridor_below_m) *
                          (d_line + g.disparity_offset_px) / g.baseline_m);
    for (int sign : {-1, 1}) {
      int last = sec.lo;
      for (int across = sec.lo + sign; std::abs(across) <= reach && std::abs(across - last) <= 2;
           across += sign) {
        if (on_surface(pixel_at(c, across, 0), sec.d_ref)) last = across;
      }
      (sign < 0 ? sec.lo : sec.hi) = last;
    }
    sections.push_back(sec);
  }
  if (sections.size() < 8) return out;
  std::vector<double> excess;
  for (const Section& sec : sections) excess.push_back(sec.hi - sec.lo + 1 - 2 * sec.conductor_px);
  const double fattening = Quantile(excess, 0.5);
  const size_t n = sections.size();
  std::vector<bool> wide(n);
  for (size_t i = 0; i < n; ++i) {
    const double band = 2 * sections[i].conductor_px + fattening;
    wide[i] = excess[i] - fattening >= std::max(o.min_widening_px, o.min_widening_relative * band);
  }
  for (size_t i = 0; i < n;) {
    if (!wide[i]) {
      ++i;
      continue;
    }
    size_t j = i;  // the run's last widened section
    for (size_t k = i + 1; k < n && sections[k].tau - sections[j].tau <= 2.0; ++k) {
      if (wide[k]) j = k;
    }
    if (sections[j].tau - sections[i].tau + 1 >= o.min_widening_length_px) {
      for (size_t k = i; k <= j; ++k) {
        const Section& sec = sections[k];
        const cv::Point2d c = line.ImagePoint(sec.tau);
        for (double across = sec.lo; across <= sec.hi; across += 0.5) {
          for (double along : {-0.5, 0.0, 0.5}) {
            const cv::Point p = pixel_at(c, across, along);
            if (on_surface(p, sec.d_ref)) out.at<std::uint8_t>(p) = 255;
          }
        }
      }
    }
    i = j + 1;
  }
  return out;
}

// Straight and along-the-line distance from the ranging chain on the obstacle's pixels only.
void Range(const RangingPipeline& pipeline, const RangingFrame& frame, const cv::Mat& disparity,
           const ConductorModel& model, cv::Mat* masked, LineObstacle* o) {
  const StereoGeometry& g = pipeline.geometry();
  for (int y = 0; y < o->box.height; ++y) {
    for (int x = 0; x < o->box.width; ++x) {
      if (o->mask.at<std::uint8_t>(y, x) == 0) continue;
      const cv::Point p(o->box.x + x, o->box.y + y);
      masked->at<float>(p) = disparity.at<float>(p);
    }
  }
  const cv::Rect image(0, 0, masked->cols, masked->rows);
  const cv::Rect roi = (o->box + cv::Size(8, 8) - cv::Point(4, 4)) & image;
  o->range = RangeObstacle(*masked, g, roi, pipeline.options().ranging);
  (*masked)(o->box).setTo(std::numeric_limits<float>::infinity());
  pipeline.RefineSurface(frame, &o->range);
  pipeline.AddModelUncertainty(&o->range);
  if (!o->range.ok() || o->range.surface_pixels.empty()) {
    // Without a measurement the run's own near end stands, with the spread of its depths.
    o->sigma_m = 0.05 * o->distance_m;
    o->arc_sigma_m = o->sigma_m;
    o->confidence *= 0.5;
    return;
  }
  o->distance_m = o->range.distance_m;
  o->sigma_m = o->range.sigma_m;
  std::vector<double> arcs;
  cv::Vec3d tangent(0, 0, 1);
  const CurveLocator locator(model.line);
  for (const cv::Point& p : o->range.surface_pixels) {
    const LinePosition at = locator.Locate(BackProjectAt(g, p.x, p.y, o->distance_m));
    arcs.push_back(at.arc_m);
    tangent = at.tangent;
  }
  o->arc_m = Quantile(arcs, 0.5);
  // A depth error moves the near end along the line by sigma / cos(line, optical axis), plus the
  // spread of the surface's arcs.
  const double along = o->sigma_m / std::max(0.2, std::fabs(tangent[2]));
  const double spread = Quantile(arcs, 0.84) - Quantile(arcs, 0.16);
  o->arc_sigma_m = std::sqrt(along * along + 0.25 * spread * spread / arcs.size());
}

}  // namespace

std::string LineObstacleTypeName(LineObstacleType type) {
  switch (type) {
    case LineObstacleType::kDamper:
      return "damper";
    case LineObstacleType::kClamp:
      return "clamp";
    case LineObstacleType::kInsulator:
      return "insulator";
    case LineObstacleType::kUnknown:
      return "unknown";
  }
  return "unknown";
}

std::map<std::string, std::string> LineMatcherParams(const std::string& method,
                                                     std::map<std::string, std::string> params) {
  const std::string name = method.empty() ? DefaultMatcherName() : method;
  if (name == "sgm" || name == "isgm") params.emplace("speckle_window", "0");
  return params;
}

void LineObstacleOptions::Check() const {
  conductor.Check();
  CheckOption(corridor_side_m > 0 && corridor_side_m <= 2, "LineObstacleOptions.corridor_side_m",
              corridor_side_m, "must be in (0, 2] m");
  CheckOption(corridor_above_m >= 0 && corridor_above_m <= 5,
              "LineObstacleOptions.corridor_above_m", corridor_above_m, "must be in [0, 5] m");
  CheckOption(corridor_below_m >= 0 && corridor_below_m <= 5,
              "LineObstacleOptions.corridor_below_m", corridor_below_m, "must be in [0, 5] m");
  CheckOption(max_arc_m > 0, "LineObstacleOptions.max_arc_m", max_arc_m, "must be > 0");
  CheckOption(cluster_gap_m > 0 && cluster_gap_m < 2, "LineObstacleOptions.cluster_gap_m",
              cluster_gap_m, "must be in (0, 2) m");
  CheckOption(attach_margin_px >= 0 && attach_margin_px <= 20,
              "LineObstacleOptions.attach_margin_px", attach_margin_px, "must be in [0, 20] px");
  CheckOption(attach_depth_m >= 0 && attach_depth_m <= 2, "LineObstacleOptions.attach_depth_m",
              attach_depth_m, "must be in [0, 2] m");
  CheckOption(speckle_window_px >= 0, "LineObstacleOptions.speckle_window_px", speckle_window_px,
              "must be >= 0");
  CheckOption(speckle_range_px >= 0 && speckle_range_px <= 100,
              "LineObstacleOptions.speckle_range_px", speckle_range_px, "must be in [0, 100] px");
  CheckOption(body_depth_band > 0 && body_depth_band <= 0.2, "LineObstacleOptions.body_depth_band",
              body_depth_band, "must be in (0, 0.2]");
  CheckOption(min_pixels >= 1, "LineObstacleOptions.min_pixels", min_pixels, "must be >= 1");
  CheckOption(min_area_m2 >= 0 && min_area_m2 < 0.1, "LineObstacleOptions.min_area_m2", min_area_m2,
              "must be in [0, 0.1) m^2");
  CheckOption(min_attached_pixels >= 1, "LineObstacleOptions.min_attached_pixels",
              min_attached_pixels, "must be >= 1");
  CheckOption(join_runs_gap_m >= 0 && join_runs_gap_m <= 1, "LineObstacleOptions.join_runs_gap_m",
              join_runs_gap_m, "must be in [0, 1] m");
  CheckOption(join_gap_m >= 0 && join_gap_m <= 1, "LineObstacleOptions.join_gap_m", join_gap_m,
              "must be in [0, 1] m");
  CheckOption(min_widening_px >= 0, "LineObstacleOptions.min_widening_px", min_widening_px,
              "must be >= 0 px");
  CheckOption(min_widening_relative >= 0, "LineObstacleOptions.min_widening_relative",
              min_widening_relative, "must be >= 0");
  CheckOption(min_widening_length_px >= 1, "LineObstacleOptions.min_widening_length_px",
              min_widening_length_px, "must be >= 1 px");
  CheckOption(insulator_min_above_m > 0, "LineObstacleOptions.insulator_min_above_m",
              insulator_min_above_m, "must be > 0");
  CheckOption(insulator_min_side_m > 0, "LineObstacleOptions.insulator_min_side_m",
              insulator_min_side_m, "must be > 0");
  CheckOption(damper_min_below_m > 0, "LineObstacleOptions.damper_min_below_m", damper_min_below_m,
              "must be > 0");
  CheckOption(foreign_min_above_m > 0, "LineObstacleOptions.foreign_min_above_m",
              foreign_min_above_m, "must be > 0");
  CheckOption(foreign_min_side_m > 0, "LineObstacleOptions.foreign_min_side_m", foreign_min_side_m,
              "must be > 0");
  CheckOption(foreign_top_band_m > 0, "LineObstacleOptions.foreign_top_band_m", foreign_top_band_m,
              "must be > 0");
  CheckOption(foreign_min_fill >= 0 && foreign_min_fill <= 1,
              "LineObstacleOptions.foreign_min_fill", foreign_min_fill, "must be in [0, 1]");
  CheckOption(foreign_min_below_m > damper_min_below_m, "LineObstacleOptions.foreign_min_below_m",
              foreign_min_below_m, "must be above damper_min_below_m");
}

nlohmann::json LineObstacle::ToJson() const {
  nlohmann::json j = {{"type", LineObstacleTypeName(type)},
                      {"arc_m", arc_m},
                      {"arc_sigma_m", arc_sigma_m},
                      {"distance_m", distance_m},
                      {"sigma_m", sigma_m},
                      {"length_m", length_m},
                      {"above_m", above_m},
                      {"below_m", below_m},
                      {"side_m", side_m},
                      {"top_side_m", top_side_m},
                      {"box", {box.x, box.y, box.width, box.height}},
                      {"pixels", pixels},
                      {"confidence", confidence},
                      {"ranged", range.ok()}};
  if (!range.ok()) j["range_reason"] = range.reason;
  return j;
}

nlohmann::json LineObstacles::ToJson() const {
  nlohmann::json list = nlohmann::json::array();
  for (const LineObstacle& o : obstacles) list.push_back(o.ToJson());
  return {
      {"conductor", conductor.ToJson()}, {"obstacles", list}, {"corridor_pixels", corridor_pixels}};
}

LineObstacles FindLineObstacles(const RangingPipeline& pipeline, const RangingFrame& frame,
                                const LineObstacleOptions& options,
                                const ConductorModel* previous) {
  options.Check();
  const cv::Mat& disparity = LineDisparity(pipeline, frame, options);
  const StereoGeometry& g = pipeline.geometry();
  ThinStructureOptions thin;
  thin.min_width_m = options.conductor.max_conductor_width_m;
  thin.min_depth_m = options.conductor.min_depth_m;
  thin.max_depth_m = options.conductor.max_depth_m;
  // The conductor is fitted outside the bodies of the body test's own depth bands.
  const cv::Rect image(0, 0, disparity.cols, disparity.rows);
  const cv::Mat conductor_bodies = BodyMask(disparity, g, image, thin);
  LineObstacles result;
  ConductorOptions conductor = options.conductor;
  conductor.searched_max_disparity_px = pipeline.search_range().max_disparity();
  result.conductor = FitConductor(disparity, g, conductor, conductor_bodies, previous);
  if (!result.conductor.ok()) return result;
  cv::Mat despeckled = Despeckle(disparity, options);
  // Far obstacles on the line are bodies too. The speckle filter is meant for stray matches, which
  // are as small in pixels as a far obstacle is: pixels the line vouches for (on its band, at its
  // depth) are kept.
  const cv::Mat widening = WideningOfTheLine(disparity, result.conductor, g, options);
  disparity.copyTo(despeckled, widening);
  ThinStructureOptions obstacle_thin = thin;
  obstacle_thin.depth_band_relative = options.body_depth_band;
  // Only the corridor's pixels are looked at, so only they need the body test.
  const cv::Mat bodies = obstacle_thin.depth_band_relative == thin.depth_band_relative
                             ? conductor_bodies
                             : BodyMask(disparity, g, image, obstacle_thin, false,
                                        CorridorBounds(result.conductor.line, g, options));
  const cv::Mat obstacle_bodies = bodies | widening;
  std::vector<LinePoint> points =
      CorridorPoints(despeckled, obstacle_bodies, g, result.conductor, options);
  result.corridor_pixels = static_cast<int>(points.size());
  cv::Mat masked(disparity.size(), CV_32FC1, cv::Scalar(std::numeric_limits<float>::infinity()));
  for (const std::vector<LinePoint>& run :
       JoinCloseRuns(SplitAlongLine(std::move(points), options.cluster_gap_m), result.conductor, g,
                     options)) {
    LineObstacle o;
    if (!Describe(run, result.conductor, g, options, &o)) continue;
    Range(pipeline, frame, despeckled, result.conductor, &masked, &o);
    result.obstacles.push_back(std::move(o));
  }
  std::sort(result.obstacles.begin(), result.obstacles.end(),
            [](const LineObstacle& a, const LineObstacle& b) { return a.arc_m < b.arc_m; });
  return result;
}

}  // namespace linesight
