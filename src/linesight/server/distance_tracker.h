// Temporal filtering of obstacle distances over a live stream (the base station's "fused" value).
//
// One track per obstacle: a constant-velocity Kalman filter on (distance, rate) whose measurement
// noise is each frame's own sigma_m, and whose process noise is white acceleration of spectral
// density `acceleration_psd` (m²/s³) — a robot on a line accelerates gently, so a few frames of
// consistent measurements pull the estimate along, while one wild measurement does not. A
// measurement whose normalised innovation exceeds `gate_sigmas` is rejected (counted); after
// `max_rejections` rejections in a row the track restarts from the measurement (the obstacle
// really moved, or the old track was wrong).
//
// Tracks are keyed: user ROIs by their index ("roi:0"), automatic detections by association — a
// detection continues the track whose last box overlaps it most (IoU >= min_iou) and whose
// predicted distance it passes the gate of; otherwise it starts a new track. Tracks not updated
// for `max_missed_frames` frames are dropped.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

namespace linesight {

struct DistanceTrackerOptions {
  double acceleration_psd = 0.05;   // white-acceleration spectral density q (m²/s³), > 0
  double gate_sigmas = 4.0;         // innovation gate (normalised, > 0)
  int max_rejections = 3;           // consecutive rejections before a track restarts (>= 1)
  double min_iou = 0.3;             // box overlap for associating automatic detections, (0, 1]
  int max_missed_frames = 10;       // frames without an update before a track is dropped (>= 1)
  double initial_rate_sigma = 1.0;  // prior sigma of the approach rate (m/s), > 0
  // An automatic track is confirmed (reported) after this many accepted measurements: a region
  // seen once is more often a fragment of the background than an obstacle. ROI tracks are
  // confirmed at once (the user asked for them).
  int confirm_updates = 3;  // >= 1

  void Check() const;
};

struct DistanceMeasurement {
  std::string key;  // "roi:N" for user ROIs; empty for an automatic detection (associated by box)
  cv::Rect box;
  double distance_m = 0;
  double sigma_m = 0;  // > 0
};

struct TrackState {
  int id = 0;             // stable over the stream
  std::string key;        // "roi:N" or "auto"
  cv::Rect box;           // last measured box
  double distance_m = 0;  // filtered distance
  double sigma_m = 0;     // its 1-sigma uncertainty
  double rate_m_s = 0;    // filtered rate of change (< 0 = approaching)
  double last_measurement_m = 0;
  int updates = 0;         // measurements accepted
  int rejections = 0;      // measurements rejected by the gate (total)
  int missed = 0;          // frames since the last accepted measurement
  bool confirmed = false;  // ROI track, or automatic with >= confirm_updates updates
  nlohmann::json ToJson() const;
};

class DistanceTracker {
 public:
  explicit DistanceTracker(const DistanceTrackerOptions& options = {});

  // One frame: predicts every track to time t_s (seconds, non-decreasing), then updates it with
  // its measurement. Returns the live tracks after the update, sorted by filtered distance.
  std::vector<TrackState> Update(double t_s, const std::vector<DistanceMeasurement>& measurements);
  // Drops every track (e.g. when the ROIs change).
  void Reset();
  std::vector<TrackState> tracks() const;

 private:
  struct Track {
    TrackState state;
    double p00 = 0, p01 = 0, p11 = 0;  // covariance of (distance, rate)
    int consecutive_rejections = 0;
  };
  void Predict(Track* track, double dt) const;
  // The measurement passes the innovation gate of the track's prediction.
  bool InGate(const Track& track, const DistanceMeasurement& m) const;
  // Returns false when the gate rejected the measurement.
  bool Correct(Track* track, const DistanceMeasurement& m) const;
  Track Start(const DistanceMeasurement& m, int id) const;

  DistanceTrackerOptions options_;
  std::vector<Track> tracks_;
  double last_t_ = 0;
  bool started_ = false;
  int next_id_ = 1;
};

double BoxIou(const cv::Rect& a, const cv::Rect& b);

}  // namespace linesight
