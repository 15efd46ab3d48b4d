#include "linesight/ranging/measurement.h"

#include <cmath>

#include "linesight/core/error.h"

namespace linesight {

FusedSurface FuseNearestSurface(double matched_px, double matched_sigma_px,
                                const std::vector<Measurement>& measurements,
                                double disagreement_weight) {
  LS_CHECK(disagreement_weight >= 0.0);
  FusedSurface fused;
  fused.disparity_px = matched_px;
  fused.sigma_px = matched_sigma_px;
  for (const Measurement& m : measurements) {
    const bool replaces = m.role == Measurement::Role::kEstimate ||
                          (m.role == Measurement::Role::kLowerBound && m.disparity_px > matched_px);
    if (!replaces && m.role != Measurement::Role::kCheck) continue;
    const double own = replaces ? m.sigma_px : 0.0;
    const double c = disagreement_weight * m.disagreement_px;
    fused.sigma_px = std::sqrt(matched_sigma_px * matched_sigma_px + own * own + c * c);
    fused.disagreement_px = m.disagreement_px;
    if (replaces) {
      fused.adopted = true;
      fused.kind = m.kind;
      fused.disparity_px = m.disparity_px;
    }
    return fused;
  }
  return fused;
}

}  // namespace linesight
