// Conductor faults measured on moving sequences with seeded defects: the robot rides the synthetic
// line (sim/power_line_sequence.h, num_defects defects drawn from the seed) and every scored frame
// goes through the chain the robot runs - rectify and match (RangingPipeline), the conductor and
// its fittings (FindLineObstacles, seeded by the previous frame's conductor), the inspection
// (InspectConductor) - and is scored against the frame's truth: its defects, and its damaged
// fittings (dampers tilted about the line, PowerLineSequenceOptions::tilted_damper_share).
//
// Scoring, per frame. A truth (a defect, or a tilted damper) is scored when its centre is between
// min_arc_m and max_arc_m along the line and at least min_visible_pixels of it are in view. A fault
// matches a truth when its stretch along the line overlaps the truth's extent widened by
// match_margin_m; pairs are matched one to one, nearest centres first. Recall is the share of
// scored truths matched (by the truth's type and by distance and size bins); type accuracy the
// share of matched faults reporting the truth's type. A false alarm is a fault in the scored range
// that matches no truth; false alarms are counted per 100 m of clean conductor inspected (the
// measured stretches in the scored range, the truths' extents taken out), frame by frame: a stretch
// inspected in ten frames counts ten times, and so does a false alarm that persists.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "linesight/line/conductor_faults.h"
#include "linesight/line/line_obstacles.h"
#include "linesight/ranging/pipeline.h"
#include "linesight/sim/power_line_sequence.h"

namespace linesight {

class ProgressBar;

struct FaultStudyOptions {
  // Sequences scored, and the seeds the inspection's thresholds were chosen on (the report warns
  // when the two overlap).
  std::vector<std::uint64_t> seeds{311, 312, 313, 314, 315, 316, 317, 318, 319, 320};
  std::vector<std::uint64_t> tuning_seeds{11, 12, 13, 14, 16, 17, 18, 19, 20, 21,
                                          22, 23, 24, 25, 26, 27, 28, 29, 30};
  // Seed set per sequence; 4 defects, half the dampers tilted, supersampling 2.
  sim::PowerLineSequenceOptions sequence;
  int frame_step = 4;
  int max_frames = 0;  // per sequence, 0 = all
  RangingPipelineOptions pipeline;
  LineObstacleOptions line;
  ConductorFaultOptions faults;
  double min_arc_m = 0.5, max_arc_m = 3.0;  // scored range along the line (m)
  int min_visible_pixels = 10;
  double match_margin_m = 0.05;
  std::vector<double> bin_edges{0.5, 1.0, 2.0, 3.0};  // distance bins (m along the line)

  FaultStudyOptions();
  void Check() const;
};

struct FaultRates {
  int scored = 0, matched = 0, typed_right = 0;
  double recall() const { return scored ? double(matched) / scored : 0.0; }
  double type_accuracy() const { return matched ? double(typed_right) / matched : 0.0; }
  nlohmann::json ToJson() const;
};

struct FaultStudyReport {
  std::string method, machine, command;
  std::vector<std::uint64_t> seeds, tuning_seeds;
  int frames = 0, frame_step = 1, no_conductor_frames = 0, not_inspected_frames = 0;
  double elapsed_s = 0;
  std::vector<double> bin_edges;
  std::vector<std::string> types;   // birdcage, broken_strands, string, sheet, nest
  std::vector<FaultRates> by_type;  // in the order of `types`
  std::vector<std::vector<FaultRates>> by_type_and_bin;  // [type][distance bin]
  // Per type, rates by size: the sizes' bin edges (m; birdcage: radius increase relative to the
  // radius instead) and their rates.
  std::map<std::string, std::vector<double>> size_edges;
  std::map<std::string, std::vector<FaultRates>> by_size;
  FaultRates all;
  int false_alarms = 0;
  std::map<std::string, int> false_alarms_by_type;
  double clean_inspected_m = 0;    // summed over frames
  double radius_median_error = 0;  // |measured / true - 1| of the conductor's radius, median
  // Dampers in the scored range whose roll was measured: measured roll - true tilt (deg), and the
  // sound ones (tilt 0) among them, how many were flagged as tilted.
  std::vector<double> damper_roll_errors_deg;
  int sound_damper_checks = 0, sound_dampers_flagged = 0;
  double RollErrorQuantile(double q) const;  // of |error| (deg), 0 without checks
  double false_alarms_per_100m() const {
    return clean_inspected_m > 0 ? 100.0 * false_alarms / clean_inspected_m : 0.0;
  }
  std::string ToMarkdown() const;
  nlohmann::json ToJson() const;
  // faults.svg: recall vs distance along the line per type.
  void WritePlots(const std::filesystem::path& dir) const;
};

// The frames RunFaultStudy scores (for a progress bar).
int FaultStudyFrames(const FaultStudyOptions& options);

FaultStudyReport RunFaultStudy(const FaultStudyOptions& options, ProgressBar* progress = nullptr);

}  // namespace linesight
