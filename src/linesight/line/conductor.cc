#include "linesight/line/conductor.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <random>

#include <fmt/format.h>
#include <opencv2/core.hpp>

#include "linesight/core/error.h"
#include "linesight/ranging/thin_structures.h"

namespace linesight {

namespace {

struct Candidate {
  float u, v, d;
};

// The tolerances of the inlier test at disparity d.
struct Tolerance {
  const ConductorOptions& o;
  const StereoGeometry& g;
  double HalfWidth(double d) const {  // px: radius at that depth plus the matcher's fattening
    return o.max_radius_m * (d + g.disparity_offset_px) / g.baseline_m + o.fattening_px + 1.0;
  }
  double Disparity(double d) const {
    return 3.0 * (o.disparity_sigma_px + o.disparity_sigma_relative * d);
  }
};

// Straight line through two candidates in (u, v, d).
struct LineHypothesis {
  cv::Point2d origin, axis;  // image origin and unit direction
  double d0 = 0, slope = 0;  // d = d0 + slope * t
};

bool Supports(const LineHypothesis& h, const Candidate& c, const Tolerance& tol) {
  const double du = c.u - h.origin.x, dv = c.v - h.origin.y;
  const double t = du * h.axis.x + dv * h.axis.y;
  const double n = -du * h.axis.y + dv * h.axis.x;
  const double d = h.d0 + h.slope * t;
  return std::fabs(n) <= tol.HalfWidth(c.d) && std::fabs(c.d - d) <= tol.Disparity(c.d);
}

// Residuals of a candidate against a fitted curve.
struct CurveResidual {
  double tau, nu, d;
};
CurveResidual Residual(const ConductorCurve& k, const Candidate& c) {
  const double du = c.u - k.centre.x, dv = c.v - k.centre.y;
  const double tau = du * k.axis.x + dv * k.axis.y;
  const double nu = du * k.normal.x + dv * k.normal.y;
  return {tau, nu - k.LateralAt(tau), c.d - k.DisparityAt(tau)};
}

// `widen` scales both tolerances (> 1 when claiming the fringe of a found conductor).
bool SupportsCurve(const ConductorCurve& k, const Candidate& c, const Tolerance& tol,
                   double tau_margin, double widen = 1.0) {
  const CurveResidual r = Residual(k, c);
  return r.tau >= k.tau_min - tau_margin && r.tau <= k.tau_max + tau_margin &&
         std::fabs(r.nu) <= widen * tol.HalfWidth(c.d) &&
         std::fabs(r.d) <= widen * tol.Disparity(c.d);
}

// Weighted least squares of the polynomial y = c0 + c1 t + ... + c_degree t^degree (degree <= 3;
// t scaled by `scale` for conditioning); the coefficients above the degree are 0.
void FitPolynomial(const std::vector<double>& t, const std::vector<double>& y,
                   const std::vector<double>& w, double scale, int degree, double out[4]) {
  const int n = degree + 1;
  cv::Mat a = cv::Mat::zeros(n, n, CV_64F), b = cv::Mat::zeros(n, 1, CV_64F);
  for (size_t i = 0; i < t.size(); ++i) {
    const double s = t[i] / scale;
    double phi[4] = {1.0, s, s * s, s * s * s};
    for (int r = 0; r < n; ++r) {
      b.at<double>(r) += w[i] * y[i] * phi[r];
      for (int c = 0; c < n; ++c) a.at<double>(r, c) += w[i] * phi[r] * phi[c];
    }
  }
  cv::Mat c;
  if (!cv::solve(a, b, c, cv::DECOMP_CHOLESKY)) {
    cv::solve(a, b, c, cv::DECOMP_SVD);
  }
  for (int k = 0; k < 4; ++k) out[k] = k < n ? c.at<double>(k) / std::pow(scale, k) : 0.0;
}

// Fits the curve to the candidates in `members` (indices) and returns it with tau range, residuals.
ConductorCurve FitCurve(const std::vector<Candidate>& all, const std::vector<int>& members,
                        const Tolerance& tol) {
  ConductorCurve k;
  // Weighted principal axis of the image positions.
  double sw = 0, su = 0, sv = 0;
  for (int i : members) {
    sw += 1;
    su += all[i].u;
    sv += all[i].v;
  }
  k.centre = {su / sw, sv / sw};
  double cuu = 0, cuv = 0, cvv = 0;
  for (int i : members) {
    const double du = all[i].u - k.centre.x, dv = all[i].v - k.centre.y;
    cuu += du * du;
    cuv += du * dv;
    cvv += dv * dv;
  }
  const double angle = 0.5 * std::atan2(2 * cuv, cuu - cvv);
  k.axis = {std::cos(angle), std::sin(angle)};
  // Orient tau towards the far end (decreasing disparity).
  double sdt = 0;
  for (int i : members) {
    sdt += all[i].d * ((all[i].u - k.centre.x) * k.axis.x + (all[i].v - k.centre.y) * k.axis.y);
  }
  if (sdt > 0) k.axis = -k.axis;
  k.normal = {-k.axis.y, k.axis.x};
  std::vector<double> tau, nu, d, w_nu, w_d;
  double scale = 1.0;
  for (int i : members) {
    const double du = all[i].u - k.centre.x, dv = all[i].v - k.centre.y;
    tau.push_back(du * k.axis.x + dv * k.axis.y);
    nu.push_back(du * k.normal.x + dv * k.normal.y);
    d.push_back(all[i].d);
    const double hw = tol.HalfWidth(all[i].d);
    w_nu.push_back(1.0 / (hw * hw));
    const double sd = tol.Disparity(all[i].d);
    w_d.push_back(1.0 / (sd * sd));
    scale = std::max(scale, std::fabs(tau.back()));
  }
  // Every stretch of the line counts alike: near the camera the conductor's image is many pixels
  // wide, far away a few, so each pixel's weight is divided by the pixels of its 8 px stretch.
  const double t_lo = *std::min_element(tau.begin(), tau.end());
  std::vector<int> per_bin(static_cast<size_t>(2 * scale / 8.0) + 2, 0);
  for (double t : tau) ++per_bin[static_cast<size_t>((t - t_lo) / 8.0)];
  for (size_t j = 0; j < tau.size(); ++j) {
    const double share = 1.0 / per_bin[static_cast<size_t>((tau[j] - t_lo) / 8.0)];
    w_nu[j] *= share;
    w_d[j] *= share;
  }
  FitPolynomial(tau, nu, w_nu, scale, tol.o.curve_degree, k.nu);
  FitPolynomial(tau, d, w_d, scale, tol.o.curve_degree, k.d);
  k.tau_min = *std::min_element(tau.begin(), tau.end());
  k.tau_max = *std::max_element(tau.begin(), tau.end());
  double e_nu = 0, e_d = 0;
  for (size_t j = 0; j < tau.size(); ++j) {
    const double t = tau[j];
    const double rn = nu[j] - k.LateralAt(t);
    const double rd = d[j] - k.DisparityAt(t);
    e_nu += rn * rn;
    e_d += rd * rd;
  }
  k.inliers = static_cast<int>(members.size());
  k.rms_nu_px = std::sqrt(e_nu / members.size());
  k.rms_d_px = std::sqrt(e_d / members.size());
  return k;
}

cv::Point3d BackProject(const StereoGeometry& g, double u, double v, double d) {
  const double z = g.DepthFromDisparity(d);
  return {(u - g.cx) * z / g.focal_px, (v - g.cy) * z / g.focal_px, z};
}

// Radius from the image width of the inliers where the conductor is wide (d >= 20 px): per 8 px
// of tau, the spread of the lateral residuals minus the fattening on both sides, in metres; the
// median over the stretches (*measured: at least 3 of them; 0 otherwise).
double EstimateRadius(const ConductorCurve& k, const std::vector<Candidate>& all,
                      const std::vector<int>& members, const ConductorOptions& o,
                      const StereoGeometry& g, bool* measured) {
  constexpr double kBinPx = 8.0;
  const int bins = static_cast<int>((k.tau_max - k.tau_min) / kBinPx) + 1;
  std::vector<double> lo(bins, 1e9), hi(bins, -1e9), dsum(bins, 0);
  std::vector<int> count(bins, 0);
  for (int i : members) {
    if (all[i].d < 20.0) continue;
    const CurveResidual r = Residual(k, all[i]);
    const int b = std::clamp(static_cast<int>((r.tau - k.tau_min) / kBinPx), 0, bins - 1);
    lo[b] = std::min(lo[b], r.nu);
    hi[b] = std::max(hi[b], r.nu);
    dsum[b] += all[i].d;
    ++count[b];
  }
  std::vector<double> radii;
  for (int b = 0; b < bins; ++b) {
    if (count[b] < 8) continue;
    const double d = dsum[b] / count[b];
    // Lateral width across the curve: nu is perpendicular to the image axis, the conductor's
    // image may lean against it; the bin's spread is its width to first order.
    const double width_px = hi[b] - lo[b] + 1.0 - 2.0 * o.fattening_px;
    radii.push_back(0.5 * width_px * g.baseline_m / (d + g.disparity_offset_px));
  }
  *measured = radii.size() >= 3;
  if (!*measured) return 0.0;
  std::nth_element(radii.begin(), radii.begin() + radii.size() / 2, radii.end());
  return std::max(0.0, radii[radii.size() / 2]);
}

// The 3D polyline of a curve's axis, from the camera's nearest point of the line on. The middle of
// the conductor's image shows the side of the tube that faces the camera, so each point is moved
// by the radius away from the camera, perpendicular to the line.
void BuildPolyline(ConductorCurve* k, const StereoGeometry& g) {
  k->points.clear();
  k->arcs.clear();
  std::vector<cv::Point3d> observed;
  const double step = 2.0;
  cv::Point3d last;
  for (double tau = k->tau_min; tau <= k->tau_max + 1e-9; tau += step) {
    const cv::Point2d p = k->ImagePoint(tau);
    const double d = k->DisparityAt(tau);
    if (!(d + g.disparity_offset_px > 0.05)) break;
    const cv::Point3d x = BackProject(g, p.x, p.y, d);
    if (!observed.empty() && cv::norm(x - last) < 0.02) continue;
    observed.push_back(x);
    last = x;
  }
  if (observed.size() < 2) {
    observed = {BackProject(g, k->ImagePoint(k->tau_min).x, k->ImagePoint(k->tau_min).y,
                            k->DisparityAt(k->tau_min)),
                BackProject(g, k->ImagePoint(k->tau_max).x, k->ImagePoint(k->tau_max).y,
                            k->DisparityAt(k->tau_max))};
  }
  if (k->radius_m > 0) {
    std::vector<cv::Point3d> axis(observed.size());
    for (size_t i = 0; i < observed.size(); ++i) {
      const cv::Point3d a = observed[i == 0 ? 0 : i - 1];
      const cv::Point3d b = observed[std::min(i + 1, observed.size() - 1)];
      const cv::Point3d t = (b - a) * (1.0 / cv::norm(b - a));
      cv::Point3d away = observed[i] - observed[i].dot(t) * t;
      away *= 1.0 / cv::norm(away);
      axis[i] = observed[i] + k->radius_m * away;
    }
    observed = std::move(axis);
  }
  // Straight extension from the near end (its first 0.3 m) back to the point nearest the camera.
  size_t far_index = 1;
  while (far_index + 1 < observed.size() && cv::norm(observed[far_index] - observed[0]) < 0.3) {
    ++far_index;
  }
  const cv::Point3d near = observed[0];
  cv::Point3d t = observed[far_index] - near;
  t *= 1.0 / cv::norm(t);
  const double s = -near.dot(t);  // foot of the perpendicular from the camera centre
  if (s < 0) k->points.push_back(near + s * t);
  k->points.insert(k->points.end(), observed.begin(), observed.end());
  // Arc 0 at the polyline's nearest point to the camera centre.
  double best = std::numeric_limits<double>::infinity(), best_arc = 0, arc = 0;
  k->arcs.push_back(0.0);
  for (size_t i = 0; i + 1 < k->points.size(); ++i) {
    const cv::Point3d a = k->points[i], b = k->points[i + 1];
    const double len = cv::norm(b - a);
    const double f = std::clamp(-a.dot(b - a) / (len * len), 0.0, 1.0);
    const double dist = cv::norm(a + f * (b - a));
    if (dist < best) {
      best = dist;
      best_arc = arc + f * len;
    }
    arc += len;
    k->arcs.push_back(arc);
  }
  for (double& a : k->arcs) a -= best_arc;
  k->closest_approach_m = best;
}

// Median 3D distance of a's observed polyline points from curve b (m).
double MedianSeparation(const ConductorCurve& a, const ConductorCurve& b) {
  std::vector<double> gaps;
  const CurveLocator on_b(b);
  for (const cv::Point3d& x : a.points) gaps.push_back(on_b.Locate(x).offset_m);
  std::nth_element(gaps.begin(), gaps.begin() + gaps.size() / 2, gaps.end());
  return gaps[gaps.size() / 2];
}

// RANSAC for the best supported straight line among `pool` (indices into `all`), then the curve.
std::optional<ConductorCurve> FindOne(const std::vector<Candidate>& all,
                                      const std::vector<int>& pool, const Tolerance& tol,
                                      const ConductorOptions& o, const ConductorCurve* seed_curve,
                                      std::mt19937_64* rng) {
  if (static_cast<int>(pool.size()) < o.min_inliers) return std::nullopt;
  // Scoring sample.
  std::vector<int> sample = pool;
  if (static_cast<int>(sample.size()) > o.max_candidates) {
    for (int i = 0; i < o.max_candidates; ++i) {
      std::swap(sample[i], sample[i + (*rng)() % (sample.size() - i)]);
    }
    sample.resize(o.max_candidates);
  }
  const double sample_share = double(sample.size()) / pool.size();
  // The sample's coordinates and tolerances as arrays, for a scoring loop the compiler vectorises
  // (the score only ranks hypotheses; the inliers are then selected in double precision).
  const size_t n = sample.size();
  std::vector<float> su(n), sv(n), sd(n), shw(n), sdt(n);
  for (size_t j = 0; j < n; ++j) {
    const Candidate& c = all[size_t(sample[j])];
    su[j] = c.u;
    sv[j] = c.v;
    sd[j] = c.d;
    shw[j] = float(tol.HalfWidth(c.d));
    sdt[j] = float(tol.Disparity(c.d));
  }
  int best_score = -1;
  LineHypothesis best;
  for (int h = 0; h < o.ransac_hypotheses; ++h) {
    const Candidate& a = all[sample[(*rng)() % sample.size()]];
    const Candidate& b = all[sample[(*rng)() % sample.size()]];
    const double du = b.u - a.u, dv = b.v - a.v;
    const double len = std::hypot(du, dv);
    if (len < 15.0) continue;
    LineHypothesis line{{a.u, a.v}, {du / len, dv / len}, a.d, (b.d - a.d) / len};
    const float ox = a.u, oy = a.v, ax = float(line.axis.x), ay = float(line.axis.y);
    const float d0 = a.d, slope = float(line.slope);
    int score = 0;
    for (size_t j = 0; j < n; ++j) {
      const float pu = su[j] - ox, pv = sv[j] - oy;
      const float t = pu * ax + pv * ay;
      const float across = pv * ax - pu * ay;
      const float off = sd[j] - (d0 + slope * t);
      score += (std::fabs(across) <= shw[j]) & (std::fabs(off) <= sdt[j]);
    }
    if (score > best_score) {
      best_score = score;
      best = line;
    }
  }
  std::vector<int> members;
  if (seed_curve != nullptr) {
    std::vector<int> seeded;
    for (int i : pool) {
      if (SupportsCurve(*seed_curve, all[i], tol, 30.0)) seeded.push_back(i);
    }
    if (seeded.size() >= 0.9 * best_score / sample_share) members = std::move(seeded);
  }
  if (members.empty()) {
    if (best_score < 0) return std::nullopt;
    for (int i : pool) {
      if (Supports(best, all[i], tol)) members.push_back(i);
    }
  }
  if (static_cast<int>(members.size()) < o.min_inliers) return std::nullopt;
  ConductorCurve curve = FitCurve(all, members, tol);
  for (int iteration = 0; iteration < 3; ++iteration) {
    std::vector<int> next;
    for (int i : pool) {
      if (SupportsCurve(curve, all[i], tol, 20.0)) next.push_back(i);
    }
    if (static_cast<int>(next.size()) < o.min_inliers) break;
    members = std::move(next);
    curve = FitCurve(all, members, tol);
  }
  return curve;
}

// Share of the curve's 8 px stretches (over its tau extent) holding at least two of `members`.
double Coverage(const ConductorCurve& k, const std::vector<Candidate>& all,
                const std::vector<int>& members) {
  constexpr double kBinPx = 8.0;
  const int bins = static_cast<int>((k.tau_max - k.tau_min) / kBinPx) + 1;
  std::vector<int> count(bins, 0);
  for (int i : members) {
    const CurveResidual r = Residual(k, all[i]);
    const int b = static_cast<int>(std::floor((r.tau - k.tau_min) / kBinPx));
    if (b >= 0 && b < bins) ++count[b];
  }
  return double(std::count_if(count.begin(), count.end(), [](int n) { return n >= 2; })) / bins;
}

// Joins pieces that one smooth curve explains: for each pair, the curve fitted to the union of
// their pixels must support (within the tolerances, inside its extent) at least 90 % of the
// union and of each piece. Two conductors side by side fail it (their lateral offset exceeds the
// tolerance); the near and far parts of one conductor, or its two sides of an obstacle, pass.
template <typename Piece>
void MergeContinuations(const std::vector<Candidate>& all, const Tolerance& tol,
                        std::vector<Piece>* pieces) {
  const auto supported = [&](const ConductorCurve& k, const std::vector<int>& members) {
    int n = 0;
    for (int i : members) n += SupportsCurve(k, all[i], tol, 0.0);
    return n;
  };
  for (bool merged = true; merged;) {
    merged = false;
    for (size_t a = 0; a < pieces->size() && !merged; ++a) {
      for (size_t b = a + 1; b < pieces->size() && !merged; ++b) {
        std::vector<int> both = (*pieces)[a].members;
        both.insert(both.end(), (*pieces)[b].members.begin(), (*pieces)[b].members.end());
        const ConductorCurve k = FitCurve(all, both, tol);
        const std::vector<int>& ma = (*pieces)[a].members;
        const std::vector<int>& mb = (*pieces)[b].members;
        if (supported(k, ma) < 0.9 * ma.size() || supported(k, mb) < 0.9 * mb.size()) continue;
        (*pieces)[a].curve = k;
        (*pieces)[a].members = std::move(both);
        pieces->erase(pieces->begin() + static_cast<long>(b));
        merged = true;
      }
    }
  }
}

}  // namespace

void ConductorOptions::Check() const {
  CheckOption(min_depth_m > 0, "ConductorOptions.min_depth_m", min_depth_m, "must be > 0");
  CheckOption(max_depth_m > min_depth_m, "ConductorOptions.max_depth_m", max_depth_m,
              "must exceed min_depth_m");
  CheckOption(max_conductor_width_m > 0, "ConductorOptions.max_conductor_width_m",
              max_conductor_width_m, "must be > 0");
  CheckOption(max_radius_m > 0 && max_radius_m < 0.2, "ConductorOptions.max_radius_m", max_radius_m,
              "must be in (0, 0.2) m");
  CheckOption(min_radius_m >= 0 && min_radius_m < max_radius_m, "ConductorOptions.min_radius_m",
              min_radius_m, "must be in [0, max_radius_m)");
  CheckOption(fattening_px >= 0 && fattening_px <= 20, "ConductorOptions.fattening_px",
              fattening_px, "must be in [0, 20] px");
  CheckOption(disparity_sigma_px > 0, "ConductorOptions.disparity_sigma_px", disparity_sigma_px,
              "must be > 0");
  CheckOption(disparity_sigma_relative >= 0 && disparity_sigma_relative < 0.5,
              "ConductorOptions.disparity_sigma_relative", disparity_sigma_relative,
              "must be in [0, 0.5)");
  CheckOption(ransac_hypotheses >= 1, "ConductorOptions.ransac_hypotheses", ransac_hypotheses,
              "must be >= 1");
  CheckOption(max_candidates >= 100, "ConductorOptions.max_candidates", max_candidates,
              "must be >= 100");
  CheckOption(min_inliers >= 10, "ConductorOptions.min_inliers", min_inliers, "must be >= 10");
  CheckOption(min_image_length_px > 0, "ConductorOptions.min_image_length_px", min_image_length_px,
              "must be > 0");
  CheckOption(min_coverage >= 0 && min_coverage <= 1, "ConductorOptions.min_coverage", min_coverage,
              "must be in [0, 1]");
  CheckOption(curve_degree >= 1 && curve_degree <= 3, "ConductorOptions.curve_degree", curve_degree,
              "must be 1, 2 or 3");
  CheckOption(max_conductors >= 1 && max_conductors <= 8, "ConductorOptions.max_conductors",
              max_conductors, "must be in [1, 8]");
}

std::string ConductorStatusName(ConductorStatus status) {
  switch (status) {
    case ConductorStatus::kOk:
      return "ok";
    case ConductorStatus::kNoDisparity:
      return "no_disparity";
    case ConductorStatus::kNoConductor:
      return "no_conductor";
    case ConductorStatus::kEndOn:
      return "end_on";
    case ConductorStatus::kAmbiguous:
      return "ambiguous";
  }
  return "unknown";
}

cv::Point2d ConductorCurve::ImagePoint(double tau) const {
  return centre + tau * axis + LateralAt(tau) * normal;
}

void ConductorCurve::ImageCoordinates(double u, double v, double* tau, double* lateral_px) const {
  const double du = u - centre.x, dv = v - centre.y;
  *tau = du * axis.x + dv * axis.y;
  *lateral_px = du * normal.x + dv * normal.y - LateralAt(*tau);
}

double ConductorCurve::LateralAt(double tau) const {
  return nu[0] + tau * (nu[1] + tau * (nu[2] + tau * nu[3]));
}

double ConductorCurve::DisparityAt(double tau) const {
  return d[0] + tau * (d[1] + tau * (d[2] + tau * d[3]));
}

LinePosition LocateOnCurve(const ConductorCurve& k, const cv::Point3d& x) {
  return CurveLocator(k).Locate(x);
}

LinePosition ConductorModel::Locate(const cv::Point3d& x) const { return LocateOnCurve(line, x); }

CurveLocator::CurveLocator(const ConductorCurve& k) {
  const size_t n = k.points.size();
  for (size_t i = 0; i + 1 < n; ++i) {
    Segment s;
    s.a = k.points[i];
    s.ab = k.points[i + 1] - s.a;
    s.len2 = s.ab.dot(s.ab);
    s.len = std::sqrt(s.len2);
    s.arc = k.arcs[i];
    s.lo = i == 0 ? -1e9 : 0.0;
    s.hi = i + 2 == n ? 1e9 : 1.0;
    s.tangent = cv::Vec3d(s.ab.x / s.len, s.ab.y / s.len, s.ab.z / s.len);
    s.down = cv::Vec3d(0, 1, 0) - s.tangent[1] * s.tangent;
    s.down *= 1.0 / cv::norm(s.down);
    s.side = s.tangent.cross(s.down);
    segments_.push_back(s);
  }
  // The end segments extend to infinity; the tree holds the ones between them.
  const int interior = std::max(0, int(segments_.size()) - 2);
  if (interior > 0) {
    nodes_.resize(size_t(4 * interior));
    Build(0, 1, 1 + interior);
  }
}

void CurveLocator::Build(int node, int first, int last) {
  constexpr int kLeafSegments = 4;
  Node& nd = nodes_[size_t(node)];
  nd.first = first;
  nd.last = last;
  cv::Point3d lo(1e300, 1e300, 1e300), hi(-1e300, -1e300, -1e300);
  for (int i = first; i < last; ++i) {
    for (const cv::Point3d& p :
         {segments_[size_t(i)].a, segments_[size_t(i)].a + segments_[size_t(i)].ab}) {
      lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
      hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
    }
  }
  nd.centre = 0.5 * (lo + hi);
  // Half the box's diagonal holds every endpoint, so every segment between them; a non-finite
  // point makes it infinite (the branch is always searched).
  nd.radius = 0.5 * cv::norm(hi - lo) * (1 + 1e-12) + 1e-12;
  if (!std::isfinite(nd.radius)) nd.radius = std::numeric_limits<double>::infinity();
  if (last - first > kLeafSegments) {
    const int mid = first + (last - first) / 2;
    Build(2 * node + 1, first, mid);
    Build(2 * node + 2, mid, last);
  } else {
    nd.leaf = true;
  }
}

struct CurveLocator::Nearest {
  double dist = std::numeric_limits<double>::infinity();
  int index = -1;
  double f = 0;
  cv::Point3d foot;
};

void CurveLocator::Visit(const Segment& s, int index, const cv::Point3d& x, Nearest* best) const {
  const double f = std::clamp((x - s.a).dot(s.ab) / s.len2, s.lo, s.hi);
  const cv::Point3d foot = s.a + f * s.ab;
  const double dist = cv::norm(x - foot);
  // The first of equally near segments, as a scan in polyline order finds.
  if (dist < best->dist || (dist == best->dist && index < best->index)) {
    *best = {dist, index, f, foot};
  }
}

void CurveLocator::Search(int node, const cv::Point3d& x, Nearest* best) const {
  const Node& nd = nodes_[size_t(node)];
  if (cv::norm(x - nd.centre) - nd.radius > best->dist) return;
  if (nd.leaf) {
    for (int i = nd.first; i < nd.last; ++i) Visit(segments_[size_t(i)], i, x, best);
    return;
  }
  // The nearer child first, so that the farther one is more often skipped.
  const int a = 2 * node + 1, b = 2 * node + 2;
  const bool a_first =
      cv::norm(x - nodes_[size_t(a)].centre) <= cv::norm(x - nodes_[size_t(b)].centre);
  Search(a_first ? a : b, x, best);
  Search(a_first ? b : a, x, best);
}

LinePosition CurveLocator::Locate(const cv::Point3d& x) const {
  LinePosition result;
  if (segments_.empty()) return result;
  Nearest best;
  Visit(segments_.front(), 0, x, &best);
  if (segments_.size() > 1) {
    Visit(segments_.back(), int(segments_.size()) - 1, x, &best);
  }
  if (!nodes_.empty()) Search(0, x, &best);
  if (best.index < 0) return result;
  const Segment& s = segments_[size_t(best.index)];
  result.arc_m = s.arc + best.f * s.len;
  result.offset_m = best.dist;
  const cv::Vec3d e(x.x - best.foot.x, x.y - best.foot.y, x.z - best.foot.z);
  result.down_m = e.dot(s.down);
  result.side_m = e.dot(s.side);
  result.tangent = s.tangent;
  return result;
}

nlohmann::json ConductorModel::ToJson() const {
  auto curve_json = [](const ConductorCurve& k) {
    nlohmann::json points = nlohmann::json::array();
    for (size_t i = 0; i < k.points.size(); ++i) {
      points.push_back({k.arcs[i], k.points[i].x, k.points[i].y, k.points[i].z});
    }
    nlohmann::json image = nlohmann::json::array();
    const int steps = 16;
    for (int s = 0; s <= steps; ++s) {
      const double tau = k.tau_min + (k.tau_max - k.tau_min) * s / steps;
      const cv::Point2d p = k.ImagePoint(tau);
      image.push_back({p.x, p.y, k.DisparityAt(tau)});
    }
    return nlohmann::json{{"inliers", k.inliers},
                          {"rms_lateral_px", k.rms_nu_px},
                          {"rms_disparity_px", k.rms_d_px},
                          {"radius_m", k.radius_m},
                          {"closest_approach_m", k.closest_approach_m},
                          {"image_uvd", image},
                          {"axis_arc_xyz_m", points}};
  };
  nlohmann::json j = {{"status", ConductorStatusName(status)}, {"candidates", candidates}};
  if (!reason.empty()) j["reason"] = reason;
  if (line.inliers > 0) j["line"] = curve_json(line);  // ok, or the nearest of an ambiguous pair
  nlohmann::json rest = nlohmann::json::array();
  for (const ConductorCurve& k : others) rest.push_back(curve_json(k));
  j["others"] = rest;
  return j;
}

ConductorModel FitConductor(const cv::Mat& disparity, const StereoGeometry& geometry,
                            const ConductorOptions& options, const cv::Mat& bodies_in,
                            const ConductorModel* previous) {
  options.Check();
  CheckDisparityMap(disparity, "disparity");
  ConductorModel model;
  const double d_far = geometry.DisparityFromDepth(options.max_depth_m);
  double d_near = geometry.DisparityFromDepth(options.min_depth_m);
  if (options.searched_max_disparity_px > 0) {
    d_near = std::min(d_near, options.searched_max_disparity_px - 0.5);
  }
  cv::Mat bodies = bodies_in;
  if (bodies.empty()) {
    ThinStructureOptions thin;
    thin.min_width_m = options.max_conductor_width_m;
    thin.min_depth_m = options.min_depth_m;
    thin.max_depth_m = options.max_depth_m;
    bodies = BodyMask(disparity, geometry, cv::Rect(0, 0, disparity.cols, disparity.rows), thin);
  }
  CheckOption(bodies.size() == disparity.size() && bodies.type() == CV_8UC1, "bodies", bodies.cols,
              "must be a CV_8UC1 mask of the disparity map's size");
  std::vector<Candidate> all;
  int valid = 0;
  for (int y = 0; y < disparity.rows; ++y) {
    const float* d = disparity.ptr<float>(y);
    const std::uint8_t* b = bodies.ptr<std::uint8_t>(y);
    for (int x = 0; x < disparity.cols; ++x) {
      if (!(d[x] >= d_far && d[x] <= d_near)) continue;
      ++valid;
      if (b[x] == 0) all.push_back({float(x), float(y), d[x]});
    }
  }
  model.candidates = static_cast<int>(all.size());
  if (valid < options.min_inliers) {
    model.status = ConductorStatus::kNoDisparity;
    model.reason = fmt::format("{} valid disparities at {}-{} m (fewer than {})", valid,
                               options.min_depth_m, options.max_depth_m, options.min_inliers);
    return model;
  }
  const Tolerance tol{options, geometry};
  std::mt19937_64 rng(options.seed);
  std::vector<int> pool(all.size());
  for (size_t i = 0; i < all.size(); ++i) pool[i] = static_cast<int>(i);
  // Pieces of conductors. The RANSAC line of a piece is straight in (u, v, d); a conductor whose
  // near part is many pixels wide and whose far part is a thin, converging line often comes out
  // as two pieces (the near one holding most pixels), and so does a conductor an obstacle cuts.
  struct Piece {
    ConductorCurve curve;
    std::vector<int> members;
  };
  std::vector<Piece> pieces;
  for (int c = 0; c < 2 * options.max_conductors; ++c) {
    const ConductorCurve* seed =
        previous != nullptr && previous->ok() && c == 0 ? &previous->line : nullptr;
    std::optional<ConductorCurve> curve = FindOne(all, pool, tol, options, seed, &rng);
    if (!curve) break;
    // Remove its support, and its fringe (the edge pixels of a wide near part that the matcher
    // spreads), before looking for the next one.
    std::vector<int> rest, members;
    for (int i : pool) {
      if (SupportsCurve(*curve, all[i], tol, 20.0)) {
        members.push_back(i);
      } else if (!SupportsCurve(*curve, all[i], tol, 40.0, 2.0)) {
        rest.push_back(i);
      }
    }
    pool = std::move(rest);
    pieces.push_back({*curve, std::move(members)});
  }
  MergeContinuations(all, tol, &pieces);
  // Curves whose points lie within 3 radii of another's (median) are one conductor.
  const double same_line_m = 3.0 * options.max_radius_m;
  std::vector<ConductorCurve> found;
  bool end_on = false;
  for (Piece& piece : pieces) {
    ConductorCurve* curve = &piece.curve;
    if (curve->tau_max - curve->tau_min < options.min_image_length_px) {
      end_on = end_on || found.empty();
      continue;
    }
    if (Coverage(*curve, all, piece.members) < options.min_coverage) continue;
    bool measured = false;
    curve->radius_m = EstimateRadius(*curve, all, piece.members, options, geometry, &measured);
    // A conductor has a width: where it is near enough for the width to be measured, a curve
    // narrower than the thinnest conductor is matching fill or fringe lined up by chance.
    if (measured && curve->radius_m < options.min_radius_m) continue;
    BuildPolyline(curve, geometry);
    // The fringe of a conductor already found (edge pixels outside its tolerance) is not another.
    const bool same = std::any_of(found.begin(), found.end(), [&](const ConductorCurve& k) {
      return MedianSeparation(*curve, k) < same_line_m;
    });
    if (!same) found.push_back(*curve);
  }
  if (found.empty()) {
    model.status = end_on ? ConductorStatus::kEndOn : ConductorStatus::kNoConductor;
    model.reason =
        end_on ? fmt::format("the supporting pixels span less than {} px: a conductor seen end-on",
                             options.min_image_length_px)
               : fmt::format("no line among {} thin-structure pixels has {} supporting pixels",
                             all.size(), options.min_inliers);
    return model;
  }
  std::stable_sort(found.begin(), found.end(),
                   [](const ConductorCurve& a, const ConductorCurve& b) {
                     return a.closest_approach_m < b.closest_approach_m;
                   });
  // With a tracked model, the curves that continue it are the robot's conductor: the robot rides
  // one conductor, so between frames its line moves only by the robot's sway. Of several such
  // curves (pieces of it that were not joined) the one nearest the tracked line is the model and
  // the rest are no other conductor. The nearest curve and the ambiguity test decide only without
  // that continuity (the first frame, a lost track).
  std::vector<bool> continues(found.size(), false);
  int robot = -1;
  if (previous != nullptr && previous->ok()) {
    double nearest = same_line_m;
    for (size_t i = 0; i < found.size(); ++i) {
      const double separation = MedianSeparation(found[i], previous->line);
      continues[i] = separation < same_line_m;
      if (continues[i] && separation < nearest) {
        nearest = separation;
        robot = static_cast<int>(i);
      }
    }
  }
  const size_t line = robot < 0 ? 0 : size_t(robot);
  model.line = found[line];
  for (size_t i = 0; i < found.size(); ++i) {
    if (i != line && !continues[i]) model.others.push_back(found[i]);
  }
  model.status = ConductorStatus::kOk;
  if (robot < 0 && !model.others.empty() &&
      model.others[0].closest_approach_m < 1.5 * model.line.closest_approach_m) {
    model.status = ConductorStatus::kAmbiguous;
    model.reason = fmt::format(
        "two conductors pass about equally near the camera ({:.2f} m and {:.2f} m): which one the "
        "robot rides is not clear",
        model.line.closest_approach_m, model.others[0].closest_approach_m);
  }
  return model;
}

}  // namespace linesight
