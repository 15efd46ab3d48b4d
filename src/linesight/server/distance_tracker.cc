#include "linesight/server/distance_tracker.h"

#include <algorithm>
#include <cmath>

#include "linesight/core/error.h"

namespace linesight {

void DistanceTrackerOptions::Check() const {
  CheckOption(acceleration_psd > 0, "DistanceTrackerOptions.acceleration_psd", acceleration_psd,
              "must be > 0 (m^2/s^3)");
  CheckOption(gate_sigmas > 0, "DistanceTrackerOptions.gate_sigmas", gate_sigmas, "must be > 0");
  CheckOption(max_rejections >= 1, "DistanceTrackerOptions.max_rejections", max_rejections,
              "must be >= 1");
  CheckOption(min_iou > 0 && min_iou <= 1, "DistanceTrackerOptions.min_iou", min_iou,
              "must be in (0, 1]");
  CheckOption(max_missed_frames >= 1, "DistanceTrackerOptions.max_missed_frames", max_missed_frames,
              "must be >= 1");
  CheckOption(confirm_updates >= 1, "DistanceTrackerOptions.confirm_updates", confirm_updates,
              "must be >= 1");
  CheckOption(initial_rate_sigma > 0, "DistanceTrackerOptions.initial_rate_sigma",
              initial_rate_sigma, "must be > 0 (m/s)");
}

nlohmann::json TrackState::ToJson() const {
  return {{"id", id},
          {"key", key},
          {"box", {box.x, box.y, box.width, box.height}},
          {"distance_m", distance_m},
          {"sigma_m", sigma_m},
          {"rate_m_s", rate_m_s},
          {"last_measurement_m", last_measurement_m},
          {"updates", updates},
          {"rejections", rejections},
          {"missed", missed},
          {"confirmed", confirmed}};
}

double BoxIou(const cv::Rect& a, const cv::Rect& b) {
  const double inter = (a & b).area();
  const double uni = static_cast<double>(a.area()) + b.area() - inter;
  return uni > 0 ? inter / uni : 0.0;
}

DistanceTracker::DistanceTracker(const DistanceTrackerOptions& options) : options_(options) {
  options_.Check();
}

void DistanceTracker::Reset() {
  tracks_.clear();
  started_ = false;
}

std::vector<TrackState> DistanceTracker::tracks() const {
  std::vector<TrackState> out;
  for (const Track& t : tracks_) out.push_back(t.state);
  return out;
}

void DistanceTracker::Predict(Track* t, double dt) const {
  if (dt <= 0) return;
  // x' = F x with F = [1 dt; 0 1]; P' = F P F^T + Q, Q of white acceleration with PSD q.
  const double q = options_.acceleration_psd;
  t->state.distance_m += t->state.rate_m_s * dt;
  const double p00 = t->p00 + dt * (2 * t->p01 + dt * t->p11) + q * dt * dt * dt / 3;
  const double p01 = t->p01 + dt * t->p11 + q * dt * dt / 2;
  const double p11 = t->p11 + q * dt;
  t->p00 = p00;
  t->p01 = p01;
  t->p11 = p11;
  t->state.sigma_m = std::sqrt(t->p00);
}

bool DistanceTracker::InGate(const Track& t, const DistanceMeasurement& m) const {
  const double s = t.p00 + m.sigma_m * m.sigma_m;  // innovation variance
  const double innovation = m.distance_m - t.state.distance_m;
  return innovation * innovation <= options_.gate_sigmas * options_.gate_sigmas * s;
}

bool DistanceTracker::Correct(Track* t, const DistanceMeasurement& m) const {
  if (!InGate(*t, m)) return false;
  const double s = t->p00 + m.sigma_m * m.sigma_m;
  const double innovation = m.distance_m - t->state.distance_m;
  const double k0 = t->p00 / s, k1 = t->p01 / s;
  t->state.distance_m += k0 * innovation;
  t->state.rate_m_s += k1 * innovation;
  const double p00 = (1 - k0) * t->p00;
  const double p01 = (1 - k0) * t->p01;
  const double p11 = t->p11 - k1 * t->p01;
  t->p00 = p00;
  t->p01 = p01;
  t->p11 = p11;
  t->state.sigma_m = std::sqrt(t->p00);
  return true;
}

DistanceTracker::Track DistanceTracker::Start(const DistanceMeasurement& m, int id) const {
  Track t;
  t.state.id = id;
  t.state.key = m.key.empty() ? "auto" : m.key;
  t.state.box = m.box;
  t.state.distance_m = m.distance_m;
  t.state.sigma_m = m.sigma_m;
  t.state.last_measurement_m = m.distance_m;
  t.state.updates = 1;
  t.p00 = m.sigma_m * m.sigma_m;
  t.p11 = options_.initial_rate_sigma * options_.initial_rate_sigma;
  return t;
}

std::vector<TrackState> DistanceTracker::Update(
    double t_s, const std::vector<DistanceMeasurement>& measurements) {
  for (const DistanceMeasurement& m : measurements) {
    if (!(m.sigma_m > 0) || !std::isfinite(m.distance_m)) {
      throw InputError("DistanceTracker: a measurement needs a finite distance and sigma > 0");
    }
  }
  const double dt = started_ ? std::max(0.0, t_s - last_t_) : 0.0;
  started_ = true;
  last_t_ = std::max(last_t_, t_s);
  for (Track& t : tracks_) {
    Predict(&t, dt);
    ++t.state.missed;
  }

  std::vector<bool> used(tracks_.size(), false);
  std::vector<Track> started;
  for (const DistanceMeasurement& m : measurements) {
    // Find the track this measurement continues.
    int best = -1;
    double best_iou = 0;
    for (size_t i = 0; i < tracks_.size(); ++i) {
      if (used[i]) continue;
      const Track& t = tracks_[i];
      if (!m.key.empty()) {
        if (t.state.key == m.key) best = static_cast<int>(i);
        continue;
      }
      if (t.state.key != "auto") continue;
      const double iou = BoxIou(t.state.box, m.box);
      if (iou >= options_.min_iou && iou > best_iou && InGate(t, m)) {
        best = static_cast<int>(i);
        best_iou = iou;
      }
    }
    if (best < 0) {
      started.push_back(Start(m, next_id_++));
      continue;
    }
    used[best] = true;
    Track& t = tracks_[best];
    t.state.box = m.box;
    t.state.last_measurement_m = m.distance_m;
    if (Correct(&t, m)) {
      ++t.state.updates;
      t.state.missed = 0;
      t.consecutive_rejections = 0;
    } else {
      ++t.state.rejections;
      if (++t.consecutive_rejections >= options_.max_rejections) {
        // The same obstacle, re-acquired: it keeps its id and its rejection count.
        const int rejections = t.state.rejections;
        t = Start(m, t.state.id);
        t.state.rejections = rejections;
      }
    }
  }
  tracks_.erase(
      std::remove_if(tracks_.begin(), tracks_.end(),
                     [&](const Track& t) { return t.state.missed >= options_.max_missed_frames; }),
      tracks_.end());
  for (Track& t : started) tracks_.push_back(std::move(t));
  for (Track& t : tracks_) {
    t.state.confirmed = t.state.key != "auto" || t.state.updates >= options_.confirm_updates;
  }
  std::sort(tracks_.begin(), tracks_.end(),
            [](const Track& a, const Track& b) { return a.state.distance_m < b.state.distance_m; });
  return tracks();
}

}  // namespace linesight
