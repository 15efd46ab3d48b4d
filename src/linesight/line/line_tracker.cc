#include "linesight/line/line_tracker.h"

#include <algorithm>
#include <cmath>

#include "linesight/core/error.h"

namespace linesight {

void LineTrackerOptions::Check() const {
  CheckOption(gate_m > 0 && gate_m < 5, "LineTrackerOptions.gate_m", gate_m, "must be in (0, 5) m");
  CheckOption(gate_relative >= 0 && gate_relative < 1, "LineTrackerOptions.gate_relative",
              gate_relative, "must be in [0, 1)");
  CheckOption(window_s > 0, "LineTrackerOptions.window_s", window_s, "must be > 0 s");
  CheckOption(max_coast_s > 0, "LineTrackerOptions.max_coast_s", max_coast_s, "must be > 0 s");
  CheckOption(min_hits >= 1, "LineTrackerOptions.min_hits", min_hits, "must be >= 1");
}

nlohmann::json LineTrack::ToJson() const {
  return {{"id", id},
          {"type", LineObstacleTypeName(type)},
          {"arc_m", arc_m},
          {"arc_sigma_m", arc_sigma_m},
          {"distance_m", distance_m},
          {"sigma_m", sigma_m},
          {"approach_mps", approach_mps},
          {"time_to_reach_s", time_to_reach_s},
          {"hits", hits},
          {"first_seen_s", first_seen_s},
          {"last_seen_s", last_seen_s},
          {"box", {last.box.x, last.box.y, last.box.width, last.box.height}}};
}

LineTracker::LineTracker(const LineTrackerOptions& options) : options_(options) {
  options_.Check();
}

double LineTracker::State::Predict(double t) const {
  return fitted_arc - track.approach_mps * (t - readings.back().first);
}

// Least-squares line arc(t) = a + b (t - now) through the readings; with one reading the rate is 0.
void LineTracker::State::Fit(double now) {
  const double n = double(readings.size());
  double st = 0, sa = 0;
  for (const auto& [t, a] : readings) {
    st += t - now;
    sa += a;
  }
  const double mt = st / n, ma = sa / n;
  double stt = 0, sta = 0;
  for (const auto& [t, a] : readings) {
    stt += (t - now - mt) * (t - now - mt);
    sta += (t - now - mt) * (a - ma);
  }
  const double slope = stt > 1e-12 ? sta / stt : 0.0;
  double rss = 0;
  for (const auto& [t, a] : readings) {
    const double r = a - (ma + slope * (t - now - mt));
    rss += r * r;
  }
  track.approach_mps = -slope;
  fitted_arc = ma - slope * mt;  // the track's arc and time to reach follow from it in Update
  // The residual spread of the readings, at least the frames' own sigma, shrunk by their count.
  const double spread = n > 2 ? std::sqrt(rss / (n - 2)) : track.last.arc_sigma_m;
  track.arc_sigma_m = std::max(spread, track.last.arc_sigma_m) / std::sqrt(n);
}

std::vector<LineTrack> LineTracker::Update(double timestamp_s,
                                           const std::vector<LineObstacle>& obstacles) {
  CheckOption(!started_ || timestamp_s > now_, "timestamp_s", timestamp_s,
              "must increase from frame to frame");
  started_ = true;
  now_ = timestamp_s;
  // Nearest (track, obstacle) pairs first, inside the gate.
  struct Pair {
    double gap;
    size_t track, obstacle;
  };
  std::vector<Pair> pairs;
  for (size_t i = 0; i < states_.size(); ++i) {
    const double predicted = states_[i].Predict(timestamp_s);
    for (size_t j = 0; j < obstacles.size(); ++j) {
      const double gap = std::fabs(obstacles[j].arc_m - predicted);
      if (gap <= options_.gate_m + options_.gate_relative * std::fabs(predicted)) {
        pairs.push_back({gap, i, j});
      }
    }
  }
  std::sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) { return a.gap < b.gap; });
  std::vector<int> track_of(obstacles.size(), -1);
  std::vector<bool> taken(states_.size(), false);
  for (const Pair& p : pairs) {
    if (taken[p.track] || track_of[p.obstacle] >= 0) continue;
    taken[p.track] = true;
    track_of[p.obstacle] = static_cast<int>(p.track);
  }
  for (size_t j = 0; j < obstacles.size(); ++j) {
    if (track_of[j] < 0) {
      State s;
      s.track.id = next_id_++;
      s.track.first_seen_s = timestamp_s;
      track_of[j] = static_cast<int>(states_.size());
      states_.push_back(std::move(s));
    }
    State& s = states_[size_t(track_of[j])];
    const LineObstacle& o = obstacles[j];
    s.readings.emplace_back(timestamp_s, o.arc_m);
    while (timestamp_s - s.readings.front().first > options_.window_s) s.readings.pop_front();
    s.votes[size_t(o.type)] += std::max(0.05, o.confidence);
    s.track.type =
        LineObstacleType(std::max_element(s.votes.begin(), s.votes.end()) - s.votes.begin());
    s.track.distance_m = o.distance_m;
    s.track.sigma_m = o.sigma_m;
    s.track.hits += 1;
    s.track.last_seen_s = timestamp_s;
    s.track.last = o;
    s.Fit(timestamp_s);
  }
  // Every track's arc now (coasting ones move on by their rate) and its time to reach; stale ones
  // and those behind the robot go.
  std::vector<State> kept;
  for (State& s : states_) {
    s.track.arc_m = s.Predict(timestamp_s);
    s.track.time_to_reach_s =
        s.track.approach_mps > 1e-3 ? std::max(0.0, s.track.arc_m) / s.track.approach_mps : -1.0;
    const bool stale = timestamp_s - s.track.last_seen_s > options_.max_coast_s;
    if (!stale && s.track.arc_m > -0.2) kept.push_back(std::move(s));
  }
  states_ = std::move(kept);
  return Tracks();
}

std::vector<LineTrack> LineTracker::Tracks() const {
  std::vector<LineTrack> out;
  for (const State& s : states_) {
    if (s.track.hits >= options_.min_hits) out.push_back(s.track);
  }
  std::sort(out.begin(), out.end(),
            [](const LineTrack& a, const LineTrack& b) { return a.arc_m < b.arc_m; });
  return out;
}

}  // namespace linesight
