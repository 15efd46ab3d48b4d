// The conductor's faults seen recently, over a live stream: the base station's "Faults on the
// line" list. One entry per physical fault, merged from the sightings of every inspected frame
// (InspectConductor, line/conductor_faults.h), each with the frame it was last seen and a small
// JPEG crop of the rectified left image around it.
//
// Method. A fault is fixed on the line, so its arc from the robot shrinks as the robot advances:
// seen at arc a at time t, it is expected at a - v * (t' - t) at time t', where v is the robot's
// speed along the line. The caller gives v when it knows it (the base station: the median
// approach rate of the line's tracked obstacles, which are fixed to the line too); without it the
// last speed given holds (0 at the start). A sighting continues the kept fault of its kind (the
// same type, or both foreign objects: IsForeignObject) whose expected arc is nearest, within
// gate_m plus gate_relative of the arc (the arc's noise grows with it, and the gate absorbs an
// error of the speed between two frames); nearest pairs are matched first and each kept fault
// takes at most one sighting per frame. Any other sighting is a new
// fault with the next id. A fault keeps its last sighting (arc, extent, size, confidence, box,
// crop), its expected arc now (negative once the robot has passed it) and how often it was seen.
// At most max_faults are kept: beyond that the one seen longest ago is dropped, with its crop.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "linesight/line/conductor_faults.h"

namespace linesight {

// Encoded JPEG bytes, shared and never changed once made: readers keep them without copying.
using JpegBytes = std::shared_ptr<const std::vector<uint8_t>>;

struct FaultLogOptions {
  // Faults kept (1..1000); beyond it the one seen longest ago is dropped.
  int max_faults = 32;
  // A sighting continues a kept fault of its type whose expected arc is within gate_m (m) plus
  // gate_relative times the arc of it (gate_m > 0, gate_relative >= 0).
  double gate_m = 0.15;
  double gate_relative = 0.10;
  // The crop: the fault's box grown by half its longer side (at least crop_margin_px on each
  // side, px >= 0), scaled down to at most crop_max_px on its longer side (16..2048 px).
  int crop_margin_px = 12;
  int crop_max_px = 240;
  int jpeg_quality = 85;  // 1..100

  void Check() const;
};

struct LoggedFault {
  int id = 0;            // stable over the stream, from 1
  ConductorFault last;   // the last sighting (arc from the robot then, extent, size, box)
  double arc_now_m = 0;  // where it is expected now along the line (m; < 0 = passed)
  int sightings = 0;     // frames it was seen in
  double max_confidence = 0;
  int64_t first_seen_frame = 0, last_seen_frame = 0;
  double first_seen_s = 0, last_seen_s = 0;
  JpegBytes crop;  // of the last sighting (null when its box was empty)

  // id, type, arc_m, arc_now_m, length_m, arc_begin_m, arc_end_m, distance_m, size_m, confidence,
  // max_confidence, box, sightings, first/last seen frame and time, and "crop": the URL of the
  // crop under `crop_url_prefix` ("<prefix><id>.jpg"), null without a crop.
  nlohmann::json ToJson(const std::string& crop_url_prefix) const;
};

// The crop of `box` from the rectified left image (8-bit grey or BGR) as JPEG; null when the box
// does not overlap the image.
JpegBytes EncodeFaultCrop(const cv::Mat& left_rectified, const cv::Rect& box,
                          const FaultLogOptions& options);

class FaultLog {
 public:
  explicit FaultLog(const FaultLogOptions& options = {});

  // Feeds one inspected frame's faults (timestamps increasing, s) with their crops (one per fault,
  // or empty for none). `robot_speed_mps`: the robot's speed along the line if known (m/s, > 0
  // forward); otherwise the last one given holds. Returns, for each fault of the frame, the id of
  // the kept fault it was merged into.
  std::vector<int> Update(int64_t frame, double timestamp_s,
                          const std::vector<ConductorFault>& faults,
                          const std::vector<JpegBytes>& crops,
                          std::optional<double> robot_speed_mps);

  // The kept faults, the most recently seen first (then nearest along the line first).
  const std::vector<LoggedFault>& faults() const { return faults_; }
  // The kept fault with this id, or null.
  const LoggedFault* Find(int id) const;
  double robot_speed_mps() const { return speed_mps_; }
  const FaultLogOptions& options() const { return options_; }

 private:
  FaultLogOptions options_;
  std::vector<LoggedFault> faults_;
  int next_id_ = 1;
  double speed_mps_ = 0;
};

}  // namespace linesight
