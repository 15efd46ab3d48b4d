// The robot's conductor inspected: its radius profile along the line, and bird-caging (a local
// swelling where the outer strands spread) found in it.
//
// Method. The conductor model (conductor.h) gives the line's image curve and its disparity d(tau)
// along it. At every pixel of the curve the rectified left image is sampled across the line (0.25
// px steps, bilinear) over the conductor's expected width plus a margin, and so is the right image
// at the same point of the line (d(tau) px to the left). The conductor shows as a band of one level
// against the background on each side; its edges are where the profile crosses half-way between
// the band's level and that side's background level (sub-pixel), which holds for any blur that is
// symmetric across the edge. The band's width in pixels times B / d(tau) is the conductor's
// diameter there: a radius profile along the line in metres, from the image's edges rather than
// from the disparity (whose edges the matcher fattens by several pixels). A sample counts only
// where the band between the expected and the measured edges lies at the line's depth where the
// matcher measured it and the two views agree on the width: where the line crosses the horizon or
// passes just in front of another surface, the crossing lies on that surface's edge instead.
// Beyond each edge, a thin bump that still differs from the background by half the band's
// contrast in both views is a protrusion (a strand end standing off); protrusions are part of the
// profile's JSON for study.
//
// The profile is compared with the conductor's own radius (the median over the profile), in units
// of the measured noise (the spread of the edges in pixels, which the radius in metres scales with
// depth): a bird-cage is where the radius exceeds the conductor's by a margin over >= 3 cm of arc.
// Stretches that overlap a fitting the obstacle finder typed (damper, clamp, insulator) belong to
// that fitting. Samples without contrast on both sides (the line in front of a tower, the terrain
// or a bright cloud edge) are not measured, and a stretch without enough measured samples gives no
// verdict: the report says how much of the line was inspected.
//
// Broken strands and foreign objects (string, sheet, nest) are not reported yet (on the tuning
// sequences the protrusions found 1 of 31 broken strands), and the swelling of a lit bird-cage
// beyond ~1 m is mostly missed: its outer strands are lighter than the band's darkest level, so the
// half-way crossings stay near the conductor's own radius (docs/algorithms/faults.md).
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "linesight/geometry/depth.h"
#include "linesight/line/line_obstacles.h"

namespace linesight {

enum class ConductorFaultType { kBirdcage };
// "birdcage" (the synthetic scene's defect name).
std::string ConductorFaultTypeName(ConductorFaultType type);

struct ConductorFaultOptions {
  double max_arc_m = 3.5;  // the line is inspected up to this arc from the robot (m)
  // Half-width of the sampled window beyond the conductor's expected edge: at least margin_px, and
  // margin_m at the line's depth (m): a strand standing off up to ~5 cm is inside it.
  double margin_px = 6.0;
  double margin_m = 0.06;
  double max_window_px = 48.0;
  // The band must differ from the background by this much on both sides (grey levels, 8-bit).
  double min_contrast = 12.0;
  // Swelling: the radius exceeds the conductor's by this share and by swelling_sigmas times the
  // noise, over at least min_swelling_length_m of arc.
  double min_swelling = 0.10;
  double swelling_sigmas = 4.0;
  double min_swelling_length_m = 0.03;
  // Stretches farther apart than this along the line are separate faults (m).
  double merge_gap_m = 0.03;
  // A stretch within this arc of a typed fitting belongs to the fitting (m).
  double fitting_margin_m = 0.05;
  // The band between the expected and the measured edges must lie at the line's disparity where
  // the matcher measured it (within depth_tolerance, at least 1 px), beyond its edge fattening.
  double fattening_px = 4.0;
  double depth_tolerance = 0.05;

  void Check() const;
};

// One sample of the profile (one pixel step along the line's image).
struct RadiusSample {
  double tau = 0;         // image arc coordinate of the curve (px)
  cv::Point2d pixel;      // the curve's point there (rectified left)
  double arc_m = 0;       // arc length along the line from the robot (m)
  double depth_m = 0;     // depth of the line there (m)
  bool measured = false;  // contrast on both sides: the edges below are meaningful
  double radius_m = 0;    // half the band's width (m)
  double radius_px = 0;
  double contrast = 0;  // the smaller of the two sides' |band - background| (grey levels)
  // Protrusion beyond each edge in the image (px; 0 = none). Side 0 is the image side towards +v
  // (below the line for an upright camera), side 1 the other.
  double protrusion_px[2] = {0, 0};
};

struct ConductorFault {
  ConductorFaultType type = ConductorFaultType::kBirdcage;
  double arc_m = 0;                       // centre of the stretch along the line (m)
  double arc_begin_m = 0, arc_end_m = 0;  // its extent (m)
  double distance_m = 0;                  // depth of the line there (m)
  // The radius increase (m).
  double size_m = 0;
  double confidence = 0;  // 0..1: the evidence above its threshold and the share measured
  cv::Rect box;           // rectified left image
  nlohmann::json ToJson() const;
};

enum class InspectionStatus {
  kOk,
  kNoConductor,   // no conductor model: nothing to inspect
  kNotInspected,  // the conductor is in view but too little of it could be measured
};
std::string InspectionStatusName(InspectionStatus status);

struct ConductorInspection {
  InspectionStatus status = InspectionStatus::kNoConductor;
  std::string reason;
  double radius_m = 0;        // the conductor's radius (median of the measured samples, m)
  double noise_px = 0;        // spread of the measured edges (px, robust sigma)
  double inspected_m = 0;     // arc length covered by measured samples (m)
  double inspected_to_m = 0;  // the farthest measured arc (m)
  std::vector<RadiusSample> profile;
  std::vector<ConductorFault> faults;  // nearest first
  nlohmann::json ToJson(bool with_profile = false) const;
};

// Inspects the robot's conductor of `line` (FindLineObstacles on the same frame) on the rectified
// pair (8-bit grey or BGR) and the matcher's checked disparity (CV_32FC1, +inf invalid;
// RangingFrame::checked_disparity).
ConductorInspection InspectConductor(const cv::Mat& left_rectified, const cv::Mat& right_rectified,
                                     const cv::Mat& disparity, const LineObstacles& line,
                                     const StereoGeometry& geometry,
                                     const ConductorFaultOptions& options);

}  // namespace linesight
