// Tracks of the obstacles on the robot's conductor over frames: one track per physical obstacle,
// its type, distance along the line, approach rate and time to reach.
//
// Method. Each track keeps the (time, arc) readings of its last `window_s` seconds. A new frame's
// obstacles are matched to the tracks by their distance along the line from each track's
// prediction (the line through its readings), nearest pairs first, within a gate of `gate_m` plus
// `gate_relative` of the distance (the arc's noise grows with it). The approach rate is the slope
// of a least-squares line through the readings, the track's arc its value now, the time to reach
// the arc over the rate. The type is the confidence-weighted vote of the frames. A track is
// reported once it has `min_hits` readings; it is dropped after `max_coast_s` without one, or
// once its predicted arc is behind the robot.
#pragma once

#include <array>
#include <deque>
#include <vector>

#include <nlohmann/json.hpp>

#include "linesight/line/line_obstacles.h"

namespace linesight {

struct LineTrackerOptions {
  double gate_m = 0.15;         // association gate (m) ...
  double gate_relative = 0.06;  // ... plus this share of the distance along the line
  double window_s = 1.5;        // readings the rate is fitted over (s)
  double max_coast_s = 1.0;     // a track without readings this long is dropped (s)
  int min_hits = 3;             // readings before a track is reported

  void Check() const;
};

struct LineTrack {
  int id = 0;
  LineObstacleType type = LineObstacleType::kUnknown;
  double arc_m = 0, arc_sigma_m = 0;   // distance along the line now (m)
  double distance_m = 0, sigma_m = 0;  // straight distance of the last reading (m)
  double approach_mps = 0;             // rate at which the arc shrinks (m/s; > 0 approaching)
  double time_to_reach_s = -1;         // arc / approach rate; -1 when not approaching
  int hits = 0;
  double first_seen_s = 0, last_seen_s = 0;
  LineObstacle last;  // the last reading

  nlohmann::json ToJson() const;
};

class LineTracker {
 public:
  explicit LineTracker(const LineTrackerOptions& options = {});

  // Feeds one frame's obstacles (timestamps increasing, s) and returns the reported tracks,
  // nearest along the line first.
  std::vector<LineTrack> Update(double timestamp_s, const std::vector<LineObstacle>& obstacles);
  std::vector<LineTrack> Tracks() const;  // the reported tracks after the last update

 private:
  struct State {
    LineTrack track;
    std::deque<std::pair<double, double>> readings;  // (t, arc)
    std::array<double, 4> votes{};                   // by LineObstacleType
    double fitted_arc = 0;                           // the fit's arc at the last reading
    double Predict(double t) const;
    void Fit(double now);
  };
  LineTrackerOptions options_;
  std::vector<State> states_;
  int next_id_ = 1;
  double now_ = 0;
  bool started_ = false;
};

}  // namespace linesight
