// The robot's conductor inspected: its radius profile along the line, and bird-caging (a local
// swelling where the outer strands spread) found in it.
//
// Method. The conductor model (conductor.h) gives the line's image curve and its disparity d(tau)
// along it. At every pixel of the curve the rectified left image is sampled across the line (0.25
// px steps, bilinear) over the conductor's expected width plus a margin, and so is the right image
// at the same point of the line (d(tau) px to the left). The conductor shows as a band against the
// background on each side. Two widths are measured in each view:
//  - its edges, where the profile crosses half-way between the band's darkest level and that
//    side's background (sub-pixel; right for any blur symmetric across the edge): the conductor's
//    radius, the median over the line;
//  - its extent, where the profile, coming in from the background next to the band (a ring about
//    the band's centre), first leaves it by extent_fraction of the contrast. A lit bird-cage's
//    spread strands are lighter than the shaded core, so its half-way edges fall inside the bulge,
//    but its outline is well off the background.
// A sample counts only where both views agree on the extent (an edge pulled by the background, the
// horizon or the ground's texture, lies elsewhere in the other view, while the conductor's outline
// is at the line's depth in both) and the band out to the extent lies at the line's depth where
// the matcher measured it. Beyond each edge, a thin bump that still differs from the background by
// half the band's contrast in both views is a protrusion (a strand end standing off); protrusions
// are part of the profile's JSON for study.
//
// The extent is compared with the clean conductor's own: a robust fit of the extent in pixels
// against f / Z (the radius, plus an offset of the blur and the lighting that does not scale with
// depth) rejects samples that are no reference, and the reference at each sample is the median of
// the inlier samples 0.15-0.6 m of arc away, carried to its depth. A bird-cage is where the extent
// exceeds the reference by a share of the radius and by the noise (the fit's robust spread) over
// >= 3 cm of arc and two samples (beyond ~2 m one pixel of the line's image spans several cm).
// Stretches that overlap an obstacle the finder found on the line (a fitting, or a foreign object,
// whose bulk widens the line's outline too) belong to that obstacle. Samples without contrast on
// both sides (the line in front of a tower, the terrain or a bright cloud edge) are not measured,
// and a stretch without enough measured samples gives no verdict: the report says how much of the
// line was inspected.
//
// Foreign objects are the line obstacles whose shape is no fitting's (FindLineObstacles types them
// "unknown": a mass on top of the line that spreads to its sides without rising into a string of
// discs, or something hanging deeper than a damper's weights): "nest" on top, "sheet" hanging.
// Thinner ones (a string or wire, a sheet seen edge-on: a few millimetres, thinner than any body
// and than the dense matcher can see) are found by a sweep at the line's depth from the band's
// edge outward (thin_attachments.h): one that hangs from the line (its far end within 45 deg of
// straight down) and is not part of an obstacle on the line is a "string", or a "sheet" when it
// is wider than min_sheet_width_m.
// Damaged fittings: every damper on the line is checked for its roll about the conductor
// (FittingState), measured about the axis that both views' band edges place beside it (the model's
// own axis is ~1 cm off); one turned by more than max_damper_roll_deg is a "damper_tilted" fault.
// Broken strands (a 3.5 mm wire standing off by millimetres to a few centimetres, mostly along the
// line) are not reported yet (on the tuning sequences the protrusions found 1 of 31); a bird-cage
// where the line crosses the horizon or passes in front of ground of its own grey is missed
// (docs/algorithms/faults.md).
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "linesight/geometry/depth.h"
#include "linesight/line/line_obstacles.h"
#include "linesight/line/thin_attachments.h"

namespace linesight {

enum class ConductorFaultType {
  kBirdcage,  // a swelling of the conductor where its outer strands have spread
  // Foreign objects: an obstacle on the line whose shape is no fitting's (line_obstacles.h), on
  // top of the line (a bird's nest) or hanging from it (a plastic sheet, a rag).
  kNest,
  kSheet,
  // A thin structure hanging from the line at its depth: a string, a rope, a wire.
  kString,
  // A damaged fitting: a damper turned about the line (its weights no longer hang straight down).
  kDamperTilted,
};
// "birdcage", "nest", "sheet", "string" (the synthetic scene's defect names), "damper_tilted".
std::string ConductorFaultTypeName(ConductorFaultType type);
// Whether a fault is a foreign object (nest, sheet, string) rather than damage to the conductor.
// One object may read as a nest in one frame and a sheet in the next (its extents above and below
// the line are alike), so sightings of foreign objects are one kind.
bool IsForeignObject(ConductorFaultType type);

struct ConductorFaultOptions {
  double max_arc_m = 3.5;  // the line is inspected up to this arc from the robot (m)
  // Half-width of the sampled window beyond the conductor's expected edge: at least margin_px, and
  // margin_m at the line's depth (m): a strand standing off up to ~5 cm is inside it.
  double margin_px = 6.0;
  double margin_m = 0.06;
  double max_window_px = 48.0;
  // The band must differ from the background by this much on both sides (grey levels, 8-bit).
  double min_contrast = 12.0;
  // Swelling: the extent exceeds the clean conductor's by min_swelling of its radius and by
  // swelling_sigmas times the noise, over at least min_swelling_length_m of arc and at least
  // min_swelling_samples samples (one per pixel of the line's image: beyond ~2 m one pixel spans
  // several cm of arc, and one sample alone is noise).
  double min_swelling = 0.10;
  double swelling_sigmas = 4.0;
  double min_swelling_length_m = 0.03;
  int min_swelling_samples = 2;
  // The band's extent on each side is where the profile, coming in from the background, first
  // differs from it by this share of the band's contrast: lit spread strands are lighter than the
  // shaded core but still well off the background (0.5 would be the half-way edge; at 0.3 the
  // background's own texture starts to count).
  double extent_fraction = 0.4;
  // Samples farther than outlier_sigmas times the noise from the fit of the extent against depth
  // are no reference for the clean conductor (a rope measured instead of the line, a swelling).
  double outlier_sigmas = 3.0;
  // The clean conductor's extent at a sample is the median of the reference samples between
  // baseline_gap_m and baseline_reach_m of arc away (m), carried to its depth: the background and
  // the lighting change along the line, and a swelling up to twice the gap long is not its own
  // reference. Fewer than min_baseline_samples there: the fit over the whole line.
  double baseline_gap_m = 0.15;
  double baseline_reach_m = 0.6;
  int min_baseline_samples = 6;
  // Stretches farther apart than this along the line are separate faults (m).
  double merge_gap_m = 0.03;
  // A stretch within this arc of an obstacle on the line (a fitting or a foreign object) belongs to
  // the obstacle (m).
  double fitting_margin_m = 0.05;
  // The band between the expected edges and the extent must lie at the line's disparity where
  // the matcher measured it (within depth_tolerance, at least 1 px), beyond its edge fattening.
  double fattening_px = 4.0;
  double depth_tolerance = 0.05;
  // Dampers (FittingState): the roll of the points at least roll_min_below_m under the conductor's
  // bottom (a damper's clamp grips the line 1 cm deep; its drop, messenger and weights hang 2-10 cm
  // under it), at least roll_min_points of them, about the axis measured within axis_reach_m of
  // arc before the damper's near end (at least 3 cross-sections). A damper turned by more than
  // max_damper_roll_deg is a fault.
  double roll_min_below_m = 0.02;
  int roll_min_points = 12;
  double axis_reach_m = 1.0;
  double max_damper_roll_deg = 7.0;
  // Thin structures leaving the line (thin_attachments.h); a hanging one at least this wide (m,
  // mean over its length) is a sheet seen edge-on, a narrower one a string.
  ThinAttachmentOptions thin;
  double min_sheet_width_m = 0.02;
  // A structure with at least this share of its pixels on or next to (2 px) an obstacle's mask, or
  // on its stretch of the line, is part of that obstacle, unless it reaches beyond_obstacle_m
  // farther below the line than the obstacle does (m).
  double max_on_obstacle_share = 0.3;
  double beyond_obstacle_m = 0.1;
  // Only points within damper_reach_m of the axis are the damper's (its weights' bottom hangs
  // 0.116 m under it; a tilted one's reaches no farther): a defect or another object next to it in
  // the image may be part of its pixels. The cross-sections' axes must agree within
  // max_axis_spread_m (robust sigma about their straight line) or the damper is not checked.
  double damper_reach_m = 0.16;
  double max_axis_spread_m = 0.004;
  // ... and the nearest of them must lie within max_axis_gap_m of arc before the damper's near end.
  double max_axis_gap_m = 0.4;

  void Check() const;
};

// One sample of the profile (one pixel step along the line's image).
struct RadiusSample {
  double tau = 0;      // image arc coordinate of the curve (px)
  cv::Point2d pixel;   // the curve's point there (rectified left)
  double arc_m = 0;    // arc length along the line from the robot (m)
  double depth_m = 0;  // depth of the line there (m)
  // Both views see the band's extent alike, at the line's depth: the extent is meaningful.
  bool measured = false;
  double extent_m = 0;  // half the band's extent (m): from background to background
  double extent_px = 0;
  double baseline_m = 0;  // the clean conductor's extent nearby (m)
  // Both views also agree on the half-way crossings: the radius is meaningful.
  bool radius_measured = false;
  double radius_m = 0;  // half the band's width between the half-way crossings (m)
  double radius_px = 0;
  double contrast = 0;  // the smaller of the two sides' |band - background| (grey levels)
  // Protrusion beyond each edge in the image (px; 0 = none). Side 0 is the image side towards +v
  // (below the line for an upright camera), side 1 the other.
  double protrusion_px[2] = {0, 0};
  // The axis from both views' half-way crossings (rectified left frame, m): the middle of the band
  // is the axis's image in each view, and their shift along the row is the axis's disparity. The
  // matcher's disparity on a thin, receding tube is pulled towards the background behind it (its
  // windows hold both), which puts the model's axis ~1 cm off where the line passes beside the
  // camera; the band's edges are the strongest features it has.
  bool axis_measured = false;
  cv::Point3d axis;
};

// The state of a fitting on the line (a damper): how far it is turned about the line.
struct FittingState {
  int obstacle = 0;  // index into LineObstacles::obstacles
  double arc_m = 0, distance_m = 0;
  // Roll of what hangs below the line about its axis (deg; > 0 to the right seen from the robot,
  // i.e. to +x of the camera; NaN when not measured). A sound damper's weights hang straight down:
  // 0. Measured from the camera's vertical, so a rolled rig reads its own roll on every fitting.
  double roll_deg = 0;
  int axis_samples = 0;      // cross-sections that placed the axis beside it (0: not measured)
  double axis_spread_m = 0;  // their robust spread about their straight line (m)
  nlohmann::json ToJson() const;
};

struct ConductorFault {
  ConductorFaultType type = ConductorFaultType::kBirdcage;
  double arc_m = 0;                       // centre of the stretch along the line (m)
  double arc_begin_m = 0, arc_end_m = 0;  // its extent (m)
  double distance_m = 0;                  // depth of the line there (m)
  // Birdcage: the largest increase of the extent over the clean conductor's (m). Nest: its largest
  // extent (above the line, along it, across it); sheet: how far it hangs or its length (m).
  // Tilted damper: how far its lowest part has swung aside (m).
  double size_m = 0;
  double roll_deg = 0;    // tilted damper: FittingState::roll_deg
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
  double radius_m = 0;     // the conductor's radius (median of the measured samples, m)
  double noise_px = 0;     // spread of the extents about the clean conductor's (px, robust sigma)
  double inspected_m = 0;  // arc length covered by measured samples (m)
  double inspected_to_m = 0;  // the farthest measured arc (m)
  std::vector<RadiusSample> profile;
  std::vector<ConductorFault> faults;  // nearest first
  std::vector<FittingState> fittings;  // the dampers on the line up to max_arc_m
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
