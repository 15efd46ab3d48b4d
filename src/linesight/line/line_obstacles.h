// Obstacles on the robot's conductor: what is attached to or hangs from the line ahead, its type,
// and how far along the line and in a straight line it is.
//
// Method. The bodies of the disparity map (BodyMask: surfaces wider than a conductor), and far
// away where an obstacle is too few pixels to be a body, the stretches where the conductor's band
// is wider than the conductor, are back-projected and placed relative to the conductor model
// (ConductorModel::Locate): arc length along the line, height above or below it, offset to the
// side. Those inside a corridor around the line are split into obstacles where the arc has a gap;
// an obstacle must touch the conductor (some of its points within the radius plus a few centimetres
// of the axis), so a tower or a branch beside the line is not one of its obstacles however near it
// is. The straight distance is the ranging chain's nearest surface of the obstacle's own pixels
// (RangeObstacle on a map that holds only them, refined on the images and with its model
// uncertainty); the distance along the line is the arc of that nearest surface: its pixels
// back-projected at that distance and located on the line (the near end of the obstacle). The type
// follows from the obstacle's extent around the line, with the matcher's edge fattening (a few
// pixels, so Z * px / f metres) removed, by the first of these that holds:
//   insulator string - reaches far above the line (a vertical string of discs)
//   unknown          - a foreign object, its shape no fitting's: a mass on top of the line that
//                      spreads to its sides (what a fitting has there, a suspension clamp's keeper
//                      and hanger, an insulator string's link up to its first disc, a damper's
//                      clamp, is as narrow as a clamp body, 44-52 mm across) and fills its outline
//                      as a solid body does (stray matches of the background that pass for a wide
//                      mass are sparse), or something hanging deeper than a damper's weights
//                      (~0.11 m under the axis)
//   insulator string - wide to the sides (the discs of a string whose top is out of view)
//   damper           - hangs below the line (the weights on their messenger cable)
//   clamp            - compact around the line
// A foreign object (a bird's nest, a plastic sheet) is an obstacle on the line all the same;
// InspectConductor (conductor_faults.h) also reports it as a fault.
#pragma once

#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "linesight/line/conductor.h"
#include "linesight/ranging/pipeline.h"

namespace linesight {

enum class LineObstacleType { kDamper, kClamp, kInsulator, kUnknown };
// "damper", "clamp", "insulator", "unknown" (the names of the synthetic scene's types).
std::string LineObstacleTypeName(LineObstacleType type);

struct LineObstacleOptions {
  ConductorOptions conductor;
  // Work on the matcher's dense map (isgm: its SGM stage filled by planes) rather than on the
  // checked pixels ranging uses: the cast faces of clamps and the interior of a near conductor
  // are textureless and mostly unchecked, so on the checked map a clamp at 1.2 m shows only its
  // keeper and the conductor's axis drifts to one edge. Fills far from the line are outside the
  // corridor and do not matter.
  bool dense_disparity = true;
  // The corridor around the conductor (m): to each side, above and below the axis. Above: 1 m
  // holds the lower part of a suspension string (the shortest strings are ~1 m) but not the tower's
  // crossarm at its top; below: a damper's weights hang ~0.12 m under the line.
  double corridor_side_m = 0.35;
  double corridor_above_m = 1.0;
  double corridor_below_m = 0.4;
  // Obstacles are bodies: surfaces at least conductor.max_conductor_width_m wide within 3
  // neighbouring depth bands of this width in ln(d) (ThinStructureOptions::depth_band_relative):
  // 0.06 holds a surface over +-9 % of its depth, so a fitting near the robot, whose faces recede
  // along the line of sight (a clamp's side 0.7-0.9 m ahead), stays one body; 0.04 cuts it into
  // strips too narrow to be bodies. The conductor is fitted outside the bodies of the body test's
  // own 0.04: with these wider bands more frames held two equally near "conductors".
  double body_depth_band = 0.06;
  double max_arc_m = 8.0;       // farther along the line is not looked at (m)
  double cluster_gap_m = 0.12;  // a gap this long along the line separates two obstacles (m)
  // ... unless the two runs' extents in the conductor's frame (along, below/above and beside the
  // line, 5th-95th percentiles) come within join_runs_gap_m of each other: one fitting may be split
  // along the line (a damper seen end-on shows its near weight's cap, then its clamp 0.18 m on,
  // the weight's body hidden behind the cap). 0.25 m is half the longest fitting (a damper,
  // 0.45 m); neighbouring fittings on a line are further apart. 0 = runs are never joined.
  double join_runs_gap_m = 0.25;
  // A pixel touches the conductor when it lies on the conductor's image band widened by this
  // margin (px) at a depth within attach_depth_m (or 1 px of disparity) of the conductor's there.
  // 0.25 m is half the length of the longest obstacle (a damper, 0.45 m): seen along the line, its
  // weights cover the band in front of and behind its clamp.
  double attach_margin_px = 2.0;
  double attach_depth_m = 0.25;
  // The conductor is fitted on the map as matched (a receding conductor is a chain of small
  // pieces a speckle filter deletes); obstacles and their distances are taken on a copy without
  // speckles: pieces of at most this many pixels whose 4-neighbours differ by at most
  // speckle_range_px (the usual 100 px / 2 px). Stray matches in front of an obstacle otherwise
  // pull its nearest surface towards the camera. 0 = no filter.
  int speckle_window_px = 100;
  double speckle_range_px = 2.0;
  int min_pixels = 25;  // fewer body pixels: not an obstacle (too small or too far)
  // Smallest visible area of an obstacle at its own depth (m^2, the sum of its pixels' footprints
  // (z / f)^2): the least a fitting shows is a damper weight's or a clamp's face seen end-on, a
  // few 10 cm^2. A pixel count alone cannot tell a near fragment (the matcher's fill where the line
  // meets a near clamp, 30-50 px at 1 m: ~1 cm^2) from a far clamp (50 px at 5 m: ~25 cm^2).
  double min_area_m2 = 5e-4;
  int min_attached_pixels = 4;  // fewer touching pixels: not on this line
  // The parts of one obstacle are joined by members too thin to be bodies (an insulator string's
  // 18 mm link from its clamp to the first disc, a damper's 13 mm messenger from its clamp to its
  // weights), so they are separate pieces in the image. A piece that does not touch the conductor
  // belongs to the obstacle when its extent in the conductor's frame (along, below/above and
  // beside the line, 5th-95th percentiles) comes within join_gap_m of a piece that does (or of one
  // joined before), or of the conductor itself: a fitting's grip may be too thin to be a body (a
  // damper's clamp is 44 mm across a 28 mm conductor), so near the robot, where the band's
  // widening is not looked for, its weights hang from the line with nothing touching it. 0.15 m
  // spans the link above a suspension clamp (0.09 m) and the messenger's gap to a damper weight
  // (~0.1 m); a tower's leg beside the line stays out. 0 = only touching pieces.
  double join_gap_m = 0.15;
  // Far obstacles that are not bodies: where the conductor's image radius is below the matcher's
  // fattening, the conductor's band at its depth widened by at least min_widening_px and by
  // min_widening_relative of the band's width, over at least min_widening_length_px of the line's
  // image arc (min_widening_px 0 = off). A 52 mm clamp 4.5 m ahead widens the band by 4-10 px over
  // 3-4 px of the image arc: the line recedes almost along the line of sight.
  double min_widening_px = 3.0;
  double min_widening_relative = 0.5;
  double min_widening_length_px = 4.0;
  // Type thresholds (m, after removing the fattening): see the file comment.
  double insulator_min_above_m = 0.25;
  double insulator_min_side_m = 0.08;
  double damper_min_below_m = 0.07;
  // Foreign objects (type unknown): on top, above_m >= foreign_min_above_m with top_side_m >=
  // foreign_min_side_m, where top_side_m is measured on the points up to foreign_top_band_m above
  // the axis (an insulator string's clamp, hanger and link reach ~0.17 m before its first disc),
  // and area_m2 at least foreign_min_fill of its outline across the view (2 top_side_m wide,
  // above_m + the conductor's radius high); hanging, below_m >= foreign_min_below_m.
  double foreign_min_above_m = 0.05;
  double foreign_min_side_m = 0.06;
  double foreign_top_band_m = 0.15;
  double foreign_min_fill = 0.3;
  double foreign_min_below_m = 0.13;

  void Check() const;
};

struct LineObstacle {
  LineObstacleType type = LineObstacleType::kUnknown;
  // Distance along the conductor from the robot (arc length, m) to the obstacle's near end, and
  // the straight distance to the camera (nearest-surface depth, m), each with its 1-sigma.
  double arc_m = 0.0, arc_sigma_m = 0.0;
  double distance_m = 0.0, sigma_m = 0.0;
  // Extent along the line, above, below and to the side of the axis (m, fattening removed).
  double length_m = 0.0, above_m = 0.0, below_m = 0.0, side_m = 0.0;
  // How far to the side what sits on top of the line reaches: the points up to foreign_top_band_m
  // above the axis (m, fattening removed; 0 without such points).
  double top_side_m = 0.0;
  double area_m2 = 0.0;  // its pixels' area at their depths (m^2)
  cv::Rect box;          // rectified left image
  cv::Mat mask;          // CV_8UC1 of the box's size, 255 on the obstacle's pixels
  int pixels = 0;
  // 0..1: how much of the obstacle supports the result (pixels seen and touching the line, a
  // ranging measurement) - the share a tracker may rely on.
  double confidence = 0.0;
  RangeResult range;  // the ranging chain's result on the obstacle's pixels

  nlohmann::json ToJson() const;
};

struct LineObstacles {
  ConductorModel conductor;
  // The obstacles on the robot's conductor, nearest along the line first (empty unless the
  // conductor model is ok: without a line there is no "on the line").
  std::vector<LineObstacle> obstacles;
  // Obstacle candidates (bodies and the widened band's pixels) inside the corridor.
  int corridor_pixels = 0;

  nlohmann::json ToJson() const;
};

// The matcher settings the line stages need, on top of the ranging chain's: for sgm and isgm the
// speckle filter off unless `params` sets "speckle_window". A conductor recedes in depth along its
// image, so its disparity changes by a pixel or more from row to row; the speckle filter splits
// it into small blobs of similar disparity and removes them, leaving only the near, wide part of
// the line (on the synthetic line, the conductor beyond ~0.6 m in most frames).
std::map<std::string, std::string> LineMatcherParams(const std::string& method,
                                                     std::map<std::string, std::string> params);

// One frame: the conductor model (seeded by `previous` if given) and the obstacles on it.
LineObstacles FindLineObstacles(const RangingPipeline& pipeline, const RangingFrame& frame,
                                const LineObstacleOptions& options,
                                const ConductorModel* previous = nullptr);

}  // namespace linesight
