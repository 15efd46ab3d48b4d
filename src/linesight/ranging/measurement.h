// Second measurements of an obstacle's nearest surface and the one rule that fuses them with the
// matched map's value.
//
// The matched map's nearest-surface disparity d_m (RangeObstacle's d_near, 1-sigma s_m) is biased
// exactly where a refiner can measure: a matcher's window blends a small front with what lies
// behind it and reads it too far. Each refiner measures the same quantity without that window and
// returns a Measurement:
//  * kEstimate: the nearest surface's disparity (the surface fit, RefineSurfaceDisparity, plus the
//    matched map's offset of d_near above the surface's mean);
//  * kLowerBound: a disparity the nearest surface lies at or in front of (the silhouette edges,
//    MeasureEdgeDisparity: every visible edge of an obstacle lies at or behind its nearest point);
//  * kCheck: a second reading that cannot correct (too few clean pixels, a correlation highest at
//    the end of its search window) but tells how far the two readings of one surface disagree.
//
// The rule (FuseNearestSurface), over the measurements in order of precedence:
//  1. the first kEstimate, or the first kLowerBound that lies above d_m, replaces d_m -- not an
//     average: the matched value is biased by about the difference on the fronts where a refiner
//     succeeds, and averaging would keep half that bias;
//  2. otherwise the first kCheck leaves d_m as it is;
//  3. either way sigma_d^2 = s_m^2 + s^2 + (w * c)^2, with s the measurement's own noise (0 for a
//     check) and c its disagreement with the matched map: where two readings of one surface
//     disagree, one of them is off by about the difference (w = surface_disagreement_weight).
// Without any usable measurement the matched value and sigma stay.
#pragma once

#include <limits>
#include <string>
#include <vector>

namespace linesight {

struct Measurement {
  enum class Role { kEstimate, kLowerBound, kCheck };
  Role role = Role::kCheck;
  std::string kind;           // "surface" or "edges": what measured it (RangeResult::refinement)
  double disparity_px = 0.0;  // the reading (for kCheck: informative only)
  double sigma_px = 0.0;      // its own noise (1 sigma)
  // Its disagreement with the matched map: the reading minus the matched value of the same
  // quantity (the surface's mean for the surface fit, d_near for the edges).
  double disagreement_px = 0.0;
};

struct FusedSurface {
  bool adopted = false;       // a measurement replaced the matched value
  std::string kind;           // the adopted measurement's kind (empty when none)
  double disparity_px = 0.0;  // the nearest surface's disparity
  double sigma_px = 0.0;      // its 1-sigma uncertainty
  // The disagreement of the measurement that decided (adopted or check); NaN when none did.
  double disagreement_px = std::numeric_limits<double>::quiet_NaN();
};

// `matched_px`, `matched_sigma_px`: d_m and s_m; `measurements` in order of precedence;
// `disagreement_weight`: w >= 0. See the file comment.
FusedSurface FuseNearestSurface(double matched_px, double matched_sigma_px,
                                const std::vector<Measurement>& measurements,
                                double disagreement_weight);

}  // namespace linesight
