// Obstacle awareness measured on moving sequences: the robot rides the synthetic line
// (sim/power_line_sequence.h) and every frame goes through the chain the robot runs - rectify and
// match (RangingPipeline), the conductor and the obstacles on it (FindLineObstacles, seeded by the
// previous frame's conductor), the tracks (LineTracker) - and is scored against the frame's truth.
//
// Scoring, per frame. A truth obstacle is scored when its near end is between min_arc_m and
// max_arc_m along the line and at least min_visible_pixels of it are in view. A detection matches
// a truth when their boxes overlap and its distance along the line is within match_tolerance of
// the truth's; pairs are matched one to one, smallest arc error first. Recall is the share of
// scored truths matched; precision the share of detections (arc within the scored range) that
// match a truth obstacle, per type by the matched truth's type (an unmatched detection counts
// against its own reported type); type accuracy the share of matched detections with the truth's
// type. Errors are relative (estimate / truth - 1) and grouped by the truth's distance along the
// line. A track follows a truth in the frames its fresh reading matches it; an identity switch is
// a change of the track following the same truth; a false track is a reported track whose
// readings never match a truth. The time to reach is scored against the truth arc over the
// robot's speed.
#pragma once

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "linesight/eval/ranging_study.h"
#include "linesight/line/line_obstacles.h"
#include "linesight/line/line_tracker.h"
#include "linesight/ranging/pipeline.h"
#include "linesight/sim/power_line_sequence.h"

namespace linesight {

class ProgressBar;

struct SequenceStudyOptions {
  // Sequences to score (seeds of sim::PowerLineSequenceOptions) and the seeds the line stages'
  // thresholds were chosen on; the report warns when the two overlap.
  std::vector<std::uint64_t> seeds{201, 202, 203, 204, 205, 206, 207, 208, 209, 210};
  std::vector<std::uint64_t> tuning_seeds{3, 4, 5, 6, 7, 8, 9};
  sim::PowerLineSequenceOptions sequence;  // seed set per sequence; supersampling 1 by default
  int frame_step = 1;                      // every n-th frame (the tracker sees n / fps steps)
  int max_frames = 0;                      // per sequence, 0 = all
  StudyCalibration calibration = StudyCalibration::kEstimated;
  int boards = 15;  // rendered board views for the estimated calibration
  RangingPipelineOptions pipeline;
  LineObstacleOptions line;
  LineTrackerOptions tracker;
  double min_arc_m = 0.5, max_arc_m = 5.0;  // scored range along the line (m)
  int min_visible_pixels = 50;              // fewer: the truth is not in view enough to score
  double match_tolerance = 0.05;            // relative, on the distance along the line
  std::vector<double> bin_edges{0.5, 1.0, 2.0, 3.0, 4.0, 5.0};  // distance bins (m along the line)
  // Write one line per scored truth that was missed and per detection in range that matches no
  // truth (seed, frame, why, the truths and detections involved) to the study's log.
  bool diagnose = false;

  SequenceStudyOptions();
  void Check() const;
};

struct SequenceRateStats {
  int scored = 0, matched = 0;              // truths in range and matched
  int detections = 0, true_detections = 0;  // detections in range and matching a truth
  int typed_right = 0;                      // of the matched, with the truth's type
  std::map<std::string, int> typed_as;      // of the matched: count per detected type
  // Why the unmatched scored truths were missed: no conductor model in that frame; a detection
  // that matches no truth overlaps the truth's box, its distance along the line off by more than
  // the tolerance; only detections of other obstacles overlap it (along a receding line a nearer
  // obstacle's box often covers a farther one's); no detection overlaps it.
  int missed_no_conductor = 0, missed_off_distance = 0, missed_covered = 0, missed_not_found = 0;
  double recall() const { return scored ? double(matched) / scored : 0.0; }
  double precision() const { return detections ? double(true_detections) / detections : 1.0; }
  double type_accuracy() const { return matched ? double(typed_right) / matched : 0.0; }
  nlohmann::json ToJson() const;
};

struct SequenceErrorStats {
  int count = 0;
  double median = 0, p95 = 0;  // of |relative error|
  nlohmann::json ToJson() const;
};

struct SequenceBin {
  double from_m = 0, to_m = 0;
  SequenceRateStats rates;
  SequenceErrorStats arc, straight;
};

// One physical obstacle of one sequence.
struct SequenceObstacle {
  std::uint64_t seed = 0;
  int id = 0;
  std::string type;
  int scored_frames = 0, detected_frames = 0, typed_frames = 0;
  // Truth arc (m) at the first frame it was detected / detected with its type (-1: never), and
  // the farthest truth arc at which it was scored.
  double first_detected_m = -1, first_typed_m = -1, farthest_scored_m = 0;
  int tracks = 0, id_switches = 0;   // distinct tracks that followed it, changes between them
  SequenceErrorStats time_to_reach;  // relative, over the frames a track followed it
};

struct SequenceStudyReport {
  std::string method, calibration, machine, command;
  std::vector<std::uint64_t> seeds, tuning_seeds;
  int frames = 0, frame_step = 1;
  double duration_s = 0;  // robot time covered by the scored frames (s)
  double elapsed_s = 0;
  double speed_mps = 0;
  std::optional<StudyEstimatedCalibration> estimated_calibration;
  nlohmann::json ranging_settings, matcher_settings;
  std::vector<std::string> types;          // damper, clamp, insulator
  std::vector<SequenceRateStats> by_type;  // in the order of `types`
  SequenceRateStats all;
  SequenceErrorStats arc, straight;  // over all matched detections
  std::vector<SequenceBin> bins;
  std::vector<SequenceObstacle> obstacles;
  int reported_tracks = 0, false_tracks = 0, id_switches = 0, no_conductor_frames = 0;
  SequenceErrorStats time_to_reach, approach_rate;  // relative, over frames a track follows a truth
  // Per matched detection (for plots and further study): truth arc, type, errors.
  struct Sample {
    double truth_arc_m = 0, arc_error = 0, straight_error = 0;
    int type = 0;  // index into types
  };
  std::vector<Sample> samples;

  double false_tracks_per_minute() const {
    return duration_s > 0 ? false_tracks / (duration_s / 60.0) : 0.0;
  }
  std::string ToMarkdown() const;
  nlohmann::json ToJson() const;
  // sequences.svg: recall and precision vs distance along the line (per type), |error| median and
  // 95th percentile vs distance (along the line and straight), every matched detection's error.
  void WritePlots(const std::filesystem::path& dir) const;
};

// Renders and scores every sequence. `progress` advances once per frame; `log` (may be null)
// receives, with options.diagnose, the diagnosis lines. Throws OptionError on bad options and
// InputError when the boards of the estimated calibration cannot be calibrated.
SequenceStudyReport RunSequenceStudy(const SequenceStudyOptions& options,
                                     ProgressBar* progress = nullptr, std::FILE* log = stderr);

// Frames RunSequenceStudy processes for `options` (for a progress bar).
int SequenceStudyFrames(const SequenceStudyOptions& options);

}  // namespace linesight
