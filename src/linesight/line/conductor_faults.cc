#include "linesight/line/conductor_faults.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "linesight/core/error.h"

namespace linesight {
namespace {

constexpr double kStep = 0.25;  // sampling step across the line (px)

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

struct Stretch {
  int first = 0, last = 0;  // sample indices
};

// Runs of flagged samples, joined across gaps of at most `gap_m` of arc.
std::vector<Stretch> Runs(const std::vector<RadiusSample>& profile,
                          const std::vector<char>& flagged, double gap_m) {
  std::vector<Stretch> runs;
  for (int i = 0; i < static_cast<int>(profile.size()); ++i) {
    if (!flagged[i]) continue;
    if (!runs.empty() && profile[i].arc_m - profile[runs.back().last].arc_m <= gap_m) {
      runs.back().last = i;
    } else {
      runs.push_back({i, i});
    }
  }
  return runs;
}

}  // namespace

std::string ConductorFaultTypeName(ConductorFaultType type) {
  switch (type) {
    case ConductorFaultType::kBirdcage:
      return "birdcage";
  }
  return "unknown";
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
  CheckOption(depth_tolerance > 0 && depth_tolerance < 1, "ConductorFaultOptions.depth_tolerance",
              depth_tolerance, "must be in (0, 1)");
}

nlohmann::json ConductorFault::ToJson() const {
  return {{"type", ConductorFaultTypeName(type)},
          {"arc_m", arc_m},
          {"arc_begin_m", arc_begin_m},
          {"arc_end_m", arc_end_m},
          {"distance_m", distance_m},
          {"size_m", size_m},
          {"confidence", confidence},
          {"box", {box.x, box.y, box.width, box.height}}};
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
  if (with_profile) {
    nlohmann::json p = nlohmann::json::array();
    for (const RadiusSample& s : profile) {
      p.push_back({{"arc_m", s.arc_m},
                   {"pixel", {s.pixel.x, s.pixel.y}},
                   {"depth_m", s.depth_m},
                   {"measured", s.measured},
                   {"radius_m", s.radius_m},
                   {"contrast", s.contrast},
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
    // The band between the expected edges and the measured ones must be at the line's depth
    // where the matcher measured it: where the line crosses the horizon or passes in front of
    // another surface, the half-way crossing can lie on that surface's edge instead.
    const double tolerance = std::max(1.0, o.depth_tolerance * d);
    bool band_at_line = true;
    for (int side = 0; side < 2 && l.measured && band_at_line; ++side) {
      const double sign = side == 0 ? 1.0 : -1.0;
      for (double off = expected_px + o.fattening_px; off < l.edge_px[side] - 1.0; off += 1.0) {
        const float v = DisparityNear(disparity, p.x + sign * off * n.x, p.y + sign * off * n.y);
        if (std::isfinite(v) && std::fabs(v - d) > tolerance) {
          band_at_line = false;
          break;
        }
      }
    }
    // Both views must also agree on the width: an edge pulled by the background (the horizon or a
    // structure just behind the line) is pulled differently in the other view.
    if (l.measured && r.measured && band_at_line &&
        std::fabs(l.radius_px - r.radius_px) <= std::max(1.0, 0.15 * expected_px)) {
      s.measured = true;
      s.radius_px = 0.5 * (l.radius_px + r.radius_px);
      s.radius_m = s.radius_px * z / g.focal_px;
      for (int side = 0; side < 2; ++side) {
        const double a = l.protrusion_px[side], b = r.protrusion_px[side];
        if (a > 0 && b > 0 && std::fabs(a - b) <= std::max(1.5, 0.25 * std::max(a, b))) {
          s.protrusion_px[side] = std::min(a, b);
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
      }
    }
  }

  // The conductor's radius and the edges' noise over the measured samples.
  std::vector<double> radii, residuals;
  for (const RadiusSample& s : out.profile) {
    if (s.measured) radii.push_back(s.radius_m);
  }
  if (radii.size() < 20) {
    out.status = InspectionStatus::kNotInspected;
    out.reason = fmt::format(
        "only {} samples of the line could be measured (too little contrast "
        "against the background)",
        radii.size());
    return out;
  }
  out.radius_m = Median(radii);
  for (const RadiusSample& s : out.profile) {
    if (s.measured) residuals.push_back(s.radius_px - out.radius_m * g.focal_px / s.depth_m);
  }
  const double centre_residual = Median(residuals);
  for (double& r : residuals) r = std::fabs(r - centre_residual);
  out.noise_px = std::max(0.05, 1.4826 * Median(residuals));
  for (size_t i = 0; i < out.profile.size(); ++i) {
    const RadiusSample& s = out.profile[i];
    if (!s.measured) continue;
    out.inspected_to_m = std::max(out.inspected_to_m, s.arc_m);
    if (i > 0 && out.profile[i - 1].measured) {
      out.inspected_m += std::fabs(s.arc_m - out.profile[i - 1].arc_m);
    }
  }
  out.status = InspectionStatus::kOk;

  // Stretches that belong to a typed fitting: within the margin of it, plus the sampled window's
  // half-width in metres (a cross-section that reaches into the fitting's image sees it).
  auto on_fitting = [&](const ConductorFault& f) {
    const double window_m =
        std::min(o.max_window_px * f.distance_m / g.focal_px,
                 out.radius_m + std::max(o.margin_px * f.distance_m / g.focal_px, o.margin_m));
    const double margin = o.fitting_margin_m + window_m;
    for (const LineObstacle& ob : line.obstacles) {
      if (ob.type == LineObstacleType::kUnknown) continue;
      if (f.arc_end_m >= ob.arc_m - margin && f.arc_begin_m <= ob.arc_m + ob.length_m + margin) {
        return true;
      }
    }
    return false;
  };
  const int n = static_cast<int>(out.profile.size());
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

  // Swelling on both sides (the radius from both edges).
  std::vector<char> swollen(n, 0);
  for (int i = 0; i < n; ++i) {
    const RadiusSample& s = out.profile[i];
    if (!s.measured) continue;
    const double expected_px = out.radius_m * g.focal_px / s.depth_m;
    swollen[i] = s.radius_m > out.radius_m * (1 + o.min_swelling) &&
                 s.radius_px - expected_px > o.swelling_sigmas * out.noise_px;
  }
  for (const Stretch& r : Runs(out.profile, swollen, o.merge_gap_m)) {
    ConductorFault f = make_fault(ConductorFaultType::kBirdcage, r);
    if (f.arc_end_m - f.arc_begin_m < o.min_swelling_length_m) continue;
    if (on_fitting(f)) continue;
    double largest = 0;
    for (int i = r.first; i <= r.last; ++i) {
      if (out.profile[i].measured) {
        largest = std::max(largest, out.profile[i].radius_m - out.radius_m);
      }
    }
    f.size_m = largest;
    out.faults.push_back(f);
  }

  std::sort(out.faults.begin(), out.faults.end(),
            [](const ConductorFault& a, const ConductorFault& b) {
              return a.arc_begin_m < b.arc_begin_m;
            });
  return out;
}

}  // namespace linesight
