#include "linesight/eval/sequence_study.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "linesight/core/error.h"
#include "linesight/core/progress.h"
#include "linesight/core/timer.h"
#include "linesight/eval/plot.h"
#include "linesight/eval/report.h"
#include "linesight/eval/study_sequences.h"
#include "linesight/ranging/ranging_settings.h"

namespace linesight {

namespace fs = std::filesystem;

SequenceStudyOptions::SequenceStudyOptions() { sequence.scene.sensor.supersampling = 1; }

void SequenceStudyOptions::Check() const {
  CheckOption(!seeds.empty(), "SequenceStudyOptions.seeds", "empty", "needs at least one seed");
  CheckOption(frame_step >= 1 && frame_step <= 100, "SequenceStudyOptions.frame_step", frame_step,
              "must be in [1, 100]");
  CheckOption(max_frames >= 0, "SequenceStudyOptions.max_frames", max_frames, "must be >= 0");
  CheckOption(boards >= 3 && boards <= 100, "SequenceStudyOptions.boards", boards,
              "must be in [3, 100]");
  CheckOption(min_arc_m > 0 && max_arc_m > min_arc_m && max_arc_m <= 50,
              "SequenceStudyOptions.max_arc_m", max_arc_m,
              "needs 0 < min_arc_m < max_arc_m <= 50 m");
  CheckOption(min_visible_pixels >= 1, "SequenceStudyOptions.min_visible_pixels",
              min_visible_pixels, "must be >= 1");
  CheckOption(match_tolerance > 0 && match_tolerance <= 0.5, "SequenceStudyOptions.match_tolerance",
              match_tolerance, "must be in (0, 0.5]");
  CheckOption(bin_edges.size() >= 2 && std::is_sorted(bin_edges.begin(), bin_edges.end()) &&
                  std::adjacent_find(bin_edges.begin(), bin_edges.end()) == bin_edges.end(),
              "SequenceStudyOptions.bin_edges", bin_edges.size(),
              "needs at least two increasing edges");
  sequence.Check();
  pipeline.Check();
  line.Check();
  tracker.Check();
}

int SequenceStudyFrames(const SequenceStudyOptions& options) {
  int total = 0;
  for (std::uint64_t seed : options.seeds) {
    const int n = StudyFrames(options, StudySequence(options, seed));
    total += (n + options.frame_step - 1) / options.frame_step;
  }
  return total;
}

nlohmann::json SequenceRateStats::ToJson() const {
  return {{"scored", scored},
          {"matched", matched},
          {"recall", recall()},
          {"detections", detections},
          {"precision", precision()},
          {"true_detections", true_detections},
          {"typed_right", typed_right},
          {"type_accuracy", type_accuracy()},
          {"typed_as", typed_as},
          {"missed",
           {{"no_conductor", missed_no_conductor},
            {"off_distance", missed_off_distance},
            {"covered", missed_covered},
            {"not_found", missed_not_found}}}};
}

nlohmann::json SequenceErrorStats::ToJson() const {
  return {{"count", count}, {"median_abs", median}, {"p95_abs", p95}};
}

namespace {

// |values| median and 95th percentile (nearest rank).
SequenceErrorStats Summarise(std::vector<double> values) {
  SequenceErrorStats s;
  s.count = static_cast<int>(values.size());
  if (values.empty()) return s;
  for (double& v : values) v = std::fabs(v);
  std::sort(values.begin(), values.end());
  s.median = values[values.size() / 2];
  const size_t rank = static_cast<size_t>(std::ceil(0.95 * double(values.size())));
  s.p95 = values[std::clamp<size_t>(rank, 1, values.size()) - 1];
  return s;
}

int TypeIndex(const std::vector<std::string>& types, const std::string& name) {
  const auto it = std::find(types.begin(), types.end(), name);
  return it == types.end() ? -1 : static_cast<int>(it - types.begin());
}

// Detection k -> index of the truth it matches (-1: none): boxes overlap and the arc within the
// tolerance; one to one, smallest relative arc error first.
std::vector<int> MatchDetections(const std::vector<LineObstacle>& found,
                                 const std::vector<sim::RenderedObstacle>& truths,
                                 double tolerance) {
  struct Pair {
    double error;
    int detection, truth;
  };
  std::vector<Pair> pairs;
  for (size_t k = 0; k < found.size(); ++k) {
    for (size_t t = 0; t < truths.size(); ++t) {
      const sim::RenderedObstacle& truth = truths[t];
      if (truth.visible_pixels == 0 || truth.near_arc_m <= 0) continue;
      const double error = std::fabs(found[k].arc_m / truth.near_arc_m - 1);
      if ((found[k].box & truth.box).area() > 0 && error <= tolerance) {
        pairs.push_back({error, static_cast<int>(k), static_cast<int>(t)});
      }
    }
  }
  std::sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) {
    return a.error < b.error || (a.error == b.error && a.detection < b.detection);
  });
  std::vector<int> match(found.size(), -1);
  std::vector<bool> taken(truths.size(), false);
  for (const Pair& p : pairs) {
    if (match[p.detection] >= 0 || taken[p.truth]) continue;
    match[p.detection] = p.truth;
    taken[p.truth] = true;
  }
  return match;
}

// The detection a fresh track's last reading is (-1: the track coasted this frame).
int DetectionOfTrack(const LineTrack& track, double now, const std::vector<LineObstacle>& found) {
  if (std::fabs(track.last_seen_s - now) > 1e-9) return -1;
  for (size_t k = 0; k < found.size(); ++k) {
    if (found[k].box == track.last.box && found[k].arc_m == track.last.arc_m) {
      return static_cast<int>(k);
    }
  }
  return -1;
}

struct Accumulator {
  std::vector<std::string> types;
  std::vector<double> edges;
  std::vector<SequenceRateStats> by_type;
  std::vector<SequenceRateStats> by_bin;
  SequenceRateStats all;
  std::vector<double> arc, straight, ttr, rate;
  std::vector<std::vector<double>> bin_arc, bin_straight;

  int Bin(double arc_m) const {
    for (size_t b = 0; b + 1 < edges.size(); ++b) {
      if (arc_m >= edges[b] && arc_m < edges[b + 1]) return static_cast<int>(b);
    }
    return arc_m == edges.back() ? static_cast<int>(edges.size()) - 2 : -1;
  }
};

std::string DescribeBox(const cv::Rect& b) {
  return fmt::format("[{},{} {}x{}]", b.x, b.y, b.width, b.height);
}

std::string DescribeTruth(const sim::RenderedObstacle& truth) {
  return fmt::format("truth {} {} at {:.2f} m along ({:.2f} m straight, {} px) {}", truth.id,
                     sim::ObstacleTypeName(truth.type), truth.near_arc_m, truth.distance_m,
                     truth.visible_pixels, DescribeBox(truth.box));
}

// `truth`: the index of the truth it matches in `truths`, or -1.
std::string DescribeDetection(const LineObstacle& d, int truth,
                              const std::vector<sim::RenderedObstacle>& truths) {
  return fmt::format("{{{} at {:.2f} m along ({:.2f} m straight) {}{}}}",
                     LineObstacleTypeName(d.type), d.arc_m, d.distance_m, DescribeBox(d.box),
                     truth >= 0 ? fmt::format(" = truth {}", truths[size_t(truth)].id) : "");
}

}  // namespace

SequenceStudyReport RunSequenceStudy(const SequenceStudyOptions& options, ProgressBar* progress,
                                     std::FILE* log) {
  options.Check();
  Stopwatch watch;
  SequenceStudyReport report;
  report.seeds = options.seeds;
  report.tuning_seeds = options.tuning_seeds;
  report.frame_step = options.frame_step;
  report.speed_mps = options.sequence.speed_mps;
  report.machine = MachineDescription();
  report.calibration = StudyCalibrationName(options.calibration);
  report.types = {sim::ObstacleTypeName(sim::ObstacleType::kDamper),
                  sim::ObstacleTypeName(sim::ObstacleType::kSuspensionClamp),
                  sim::ObstacleTypeName(sim::ObstacleType::kInsulatorString)};
  StereoCalibration calibration = sim::MakeStereoCalibration(options.sequence.scene.rig);
  if (options.calibration == StudyCalibration::kEstimated) {
    StudyEstimatedCalibration info;
    calibration = EstimateStudyCalibration(options.sequence.scene.rig, options.boards, 1000, &info);
    report.estimated_calibration = info;
  }
  RangingPipelineOptions pipeline_options = options.pipeline;
  pipeline_options.params = LineMatcherParams(pipeline_options.method, pipeline_options.params);
  const RangingPipeline pipeline(calibration, pipeline_options);
  report.method = pipeline.method();
  report.ranging_settings = RangingSettingsTable().ToJson(pipeline_options);
  report.matcher_settings = pipeline.matcher().Settings();

  Accumulator acc;
  acc.types = report.types;
  acc.edges = options.bin_edges;
  acc.by_type.resize(acc.types.size());
  acc.by_bin.resize(acc.edges.size() - 1);
  acc.bin_arc.resize(acc.by_bin.size());
  acc.bin_straight.resize(acc.by_bin.size());
  const double tol = options.match_tolerance;

  for (std::uint64_t seed : options.seeds) {
    const sim::PowerLineSequence sequence = StudySequence(options, seed);
    const int n = StudyFrames(options, sequence);
    LineTracker tracker(options.tracker);
    ConductorModel previous;
    // Per truth id of this sequence.
    std::map<int, SequenceObstacle> obstacles;
    std::map<int, int> following;            // truth id -> track id following it
    std::map<int, std::set<int>> followers;  // truth id -> tracks that followed it
    std::map<int, std::vector<double>> ttr_errors;
    std::set<int> reported, true_tracks;
    for (int index = 0; index < n; index += options.frame_step) {
      const sim::PowerLineScene scene = sequence.Render(index);
      const double now = sequence.TimestampOf(index);
      const RangingFrame frame = pipeline.Process(scene.left, scene.right);
      const LineObstacles found =
          FindLineObstacles(pipeline, frame, options.line, previous.ok() ? &previous : nullptr);
      previous = found.conductor;
      report.no_conductor_frames += !found.conductor.ok();
      if (!found.conductor.ok() && options.diagnose && log != nullptr) {
        fmt::print(log, "seed {} frame {}: no conductor model: {}: {}\n", seed, index,
                   ConductorStatusName(found.conductor.status), found.conductor.reason);
      }
      const std::vector<LineTrack> tracks = tracker.Update(now, found.obstacles);
      const std::vector<int> match = MatchDetections(found.obstacles, scene.obstacles, tol);
      std::vector<int> detection_of_truth(scene.obstacles.size(), -1);
      for (size_t k = 0; k < match.size(); ++k) {
        if (match[k] >= 0) detection_of_truth[match[k]] = static_cast<int>(k);
      }
      ++report.frames;
      report.duration_s += options.frame_step / options.sequence.fps;

      // Recall, type accuracy and errors over the scored truths.
      for (size_t t = 0; t < scene.obstacles.size(); ++t) {
        const sim::RenderedObstacle& truth = scene.obstacles[t];
        SequenceObstacle& o = obstacles[truth.id];
        o.seed = seed;
        o.id = truth.id;
        o.type = sim::ObstacleTypeName(truth.type);
        const int k = detection_of_truth[t];
        const bool typed = k >= 0 && LineObstacleTypeName(found.obstacles[k].type) == o.type;
        if (k >= 0 && o.first_detected_m < 0) o.first_detected_m = truth.near_arc_m;
        if (typed && o.first_typed_m < 0) o.first_typed_m = truth.near_arc_m;
        const bool scored = truth.near_arc_m >= options.min_arc_m &&
                            truth.near_arc_m <= options.max_arc_m &&
                            truth.visible_pixels >= options.min_visible_pixels;
        if (!scored) continue;
        ++o.scored_frames;
        o.detected_frames += k >= 0;
        o.typed_frames += typed;
        o.farthest_scored_m = std::max(o.farthest_scored_m, truth.near_arc_m);
        const int type = TypeIndex(acc.types, o.type);
        const int bin = acc.Bin(truth.near_arc_m);
        bool off_distance = false, covered = false;
        for (size_t q = 0; q < found.obstacles.size(); ++q) {
          if ((found.obstacles[q].box & truth.box).area() == 0) continue;
          (match[q] < 0 ? off_distance : covered) = true;
        }
        // Why it was missed, if it was: the counter of SequenceRateStats and the name.
        struct Miss {
          int SequenceRateStats::*counter;
          const char* name;
        };
        const Miss miss =
            !found.conductor.ok() ? Miss{&SequenceRateStats::missed_no_conductor, "no conductor"}
            : off_distance        ? Miss{&SequenceRateStats::missed_off_distance, "off in distance"}
            : covered             ? Miss{&SequenceRateStats::missed_covered, "covered"}
                                  : Miss{&SequenceRateStats::missed_not_found, "not found"};
        for (SequenceRateStats* s : {&acc.all, type >= 0 ? &acc.by_type[type] : nullptr,
                                     bin >= 0 ? &acc.by_bin[bin] : nullptr}) {
          if (s == nullptr) continue;
          ++s->scored;
          s->matched += k >= 0;
          if (k < 0) ++(s->*miss.counter);
          s->typed_right += typed;
          if (k >= 0) ++s->typed_as[LineObstacleTypeName(found.obstacles[k].type)];
        }
        if (k < 0 && options.diagnose && log != nullptr) {
          std::string line = fmt::format("seed {} frame {}: missed {} ({}): overlapping:", seed,
                                         index, DescribeTruth(truth), miss.name);
          for (size_t q = 0; q < found.obstacles.size(); ++q) {
            if ((found.obstacles[q].box & truth.box).area() == 0) continue;
            line += " " + DescribeDetection(found.obstacles[q], match[q], scene.obstacles);
          }
          fmt::print(log, "{}\n", line);
        }
        if (k < 0) continue;
        const LineObstacle& d = found.obstacles[k];
        const double arc_error = d.arc_m / truth.near_arc_m - 1;
        const double straight_error = d.distance_m / truth.distance_m - 1;
        acc.arc.push_back(arc_error);
        acc.straight.push_back(straight_error);
        if (bin >= 0) {
          acc.bin_arc[bin].push_back(arc_error);
          acc.bin_straight[bin].push_back(straight_error);
        }
        report.samples.push_back({truth.near_arc_m, arc_error, straight_error, type});
      }
      // Precision over the detections in the scored range.
      for (size_t k = 0; k < found.obstacles.size(); ++k) {
        const LineObstacle& d = found.obstacles[k];
        const double arc = match[k] >= 0 ? scene.obstacles[match[k]].near_arc_m : d.arc_m;
        if (arc < options.min_arc_m * (1 - tol) || arc > options.max_arc_m * (1 + tol)) continue;
        const int type = TypeIndex(
            acc.types, match[k] >= 0 ? sim::ObstacleTypeName(scene.obstacles[match[k]].type)
                                     : LineObstacleTypeName(d.type));
        const int bin =
            acc.Bin(std::clamp(arc, options.bin_edges.front(), options.bin_edges.back()));
        for (SequenceRateStats* s : {&acc.all, type >= 0 ? &acc.by_type[type] : nullptr,
                                     bin >= 0 ? &acc.by_bin[bin] : nullptr}) {
          if (s == nullptr) continue;
          ++s->detections;
          s->true_detections += match[k] >= 0;
        }
        if (match[k] < 0 && options.diagnose && log != nullptr) {
          std::string line = fmt::format("seed {} frame {}: false {}: overlapping:", seed, index,
                                         DescribeDetection(d, -1, scene.obstacles));
          for (const sim::RenderedObstacle& truth : scene.obstacles) {
            if ((d.box & truth.box).area() > 0) line += " " + DescribeTruth(truth);
          }
          fmt::print(log, "{}\n", line);
        }
      }
      // Tracks: which truth each fresh track follows, identity switches, time to reach.
      for (const LineTrack& track : tracks) {
        reported.insert(track.id);
        const int k = DetectionOfTrack(track, now, found.obstacles);
        if (k < 0 || match[k] < 0) continue;
        const sim::RenderedObstacle& truth = scene.obstacles[match[k]];
        true_tracks.insert(track.id);
        const auto it = following.find(truth.id);
        if (it != following.end() && it->second != track.id) {
          ++obstacles[truth.id].id_switches;
          ++report.id_switches;
        }
        following[truth.id] = track.id;
        followers[truth.id].insert(track.id);
        if (truth.near_arc_m < options.min_arc_m || truth.near_arc_m > options.max_arc_m) continue;
        const double truth_ttr = truth.near_arc_m / options.sequence.speed_mps;
        if (track.time_to_reach_s > 0) {
          ttr_errors[truth.id].push_back(track.time_to_reach_s / truth_ttr - 1);
          acc.ttr.push_back(ttr_errors[truth.id].back());
        }
        acc.rate.push_back(track.approach_mps / options.sequence.speed_mps - 1);
      }
      if (progress) {
        progress->Advance(1, fmt::format("seed {} frame {}/{}", seed, index + 1, n));
      }
    }
    for (auto& [id, o] : obstacles) {
      o.tracks = static_cast<int>(followers[id].size());
      o.time_to_reach = Summarise(ttr_errors[id]);
      if (o.scored_frames > 0 || o.first_detected_m > 0) report.obstacles.push_back(o);
    }
    report.reported_tracks += static_cast<int>(reported.size());
    for (int id : reported) report.false_tracks += !true_tracks.count(id);
  }
  report.by_type = acc.by_type;
  report.all = acc.all;
  report.arc = Summarise(acc.arc);
  report.straight = Summarise(acc.straight);
  report.time_to_reach = Summarise(acc.ttr);
  report.approach_rate = Summarise(acc.rate);
  for (size_t b = 0; b < acc.by_bin.size(); ++b) {
    report.bins.push_back({options.bin_edges[b], options.bin_edges[b + 1], acc.by_bin[b],
                           Summarise(acc.bin_arc[b]), Summarise(acc.bin_straight[b])});
  }
  report.elapsed_s = watch.ElapsedMs() / 1000.0;
  return report;
}

namespace {

std::string Pct(double v) { return fmt::format("{:.2f}", 100.0 * v); }

std::string RatesRow(const std::string& name, const SequenceRateStats& s) {
  std::vector<std::string> typed_as;
  for (const auto& [type, count] : s.typed_as)
    typed_as.push_back(fmt::format("{} {}", type, count));
  return fmt::format("| {} | {} | {} | {:.3f} | {} | {:.3f} | {:.1f} | {} |\n", name, s.scored,
                     s.matched, s.recall(), s.detections, s.precision(), 100.0 * s.type_accuracy(),
                     fmt::join(typed_as, ", "));
}

std::string Seeds(const std::vector<std::uint64_t>& seeds) {
  return fmt::format("{}", fmt::join(seeds, ", "));
}

}  // namespace

std::string SequenceStudyReport::ToMarkdown() const {
  std::string out = fmt::format(
      "Obstacle awareness on {} moving sequences (seeds {}), {} frames (every {}. frame, {:.0f} s "
      "of robot time at {} m/s); method {}, {} calibration.",
      seeds.size(), Seeds(seeds), frames, frame_step, duration_s, speed_mps, method, calibration);
  if (estimated_calibration) {
    out += fmt::format(
        " Estimated from {} of {} rendered board views: baseline {:.5f} m (true "
        "{:.5f}), stereo rms {:.3f} px.",
        estimated_calibration->views_used, estimated_calibration->views_rendered,
        estimated_calibration->baseline_m, estimated_calibration->true_baseline_m,
        estimated_calibration->rms_stereo_px);
  }
  std::vector<std::uint64_t> overlap;
  for (std::uint64_t s : seeds) {
    if (std::find(tuning_seeds.begin(), tuning_seeds.end(), s) != tuning_seeds.end()) {
      overlap.push_back(s);
    }
  }
  out += fmt::format(" The line stages were tuned on seeds {}; ", Seeds(tuning_seeds));
  out += overlap.empty() ? std::string("none of them is scored here.\n\n")
                         : fmt::format("**seeds {} are tuning seeds**.\n\n", Seeds(overlap));
  out +=
      "Per frame, truths with the near end 0.5-5 m along the line (as configured) and in view; "
      "a detection counts when its box overlaps the truth's and its distance along the line "
      "is within the match tolerance.\n\n";
  out +=
      "| type | scored | found | recall | detections | precision | type accuracy % | typed as |\n"
      "|---|---|---|---|---|---|---|---|\n";
  for (size_t t = 0; t < types.size(); ++t) out += RatesRow(types[t], by_type[t]);
  out += RatesRow("all", all);
  out +=
      "\n| along the line (m) | scored | recall | precision | arc median % | arc p95 % | "
      "straight median % | straight p95 % | missed: no conductor | missed: off in distance | "
      "missed: covered by another | missed: not found "
      "|\n|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  const auto misses = [](const SequenceRateStats& r) {
    return fmt::format("{} | {} | {} | {}", r.missed_no_conductor, r.missed_off_distance,
                       r.missed_covered, r.missed_not_found);
  };
  for (const SequenceBin& b : bins) {
    out += fmt::format("| {:.1f}-{:.1f} | {} | {:.3f} | {:.3f} | {} | {} | {} | {} | {} |\n",
                       b.from_m, b.to_m, b.rates.scored, b.rates.recall(), b.rates.precision(),
                       Pct(b.arc.median), Pct(b.arc.p95), Pct(b.straight.median),
                       Pct(b.straight.p95), misses(b.rates));
  }
  out += fmt::format("| all | {} | {:.3f} | {:.3f} | {} | {} | {} | {} | {} |\n\n", all.scored,
                     all.recall(), all.precision(), Pct(arc.median), Pct(arc.p95),
                     Pct(straight.median), Pct(straight.p95), misses(all));
  out +=
      "| seed | obstacle | type | scored frames | found % | typed % | first found at m | first "
      "typed at m | farthest scored m | tracks | id switches | time to reach median % |\n"
      "|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const SequenceObstacle& o : obstacles) {
    const auto share = [&](int n) {
      return o.scored_frames ? fmt::format("{:.0f}", 100.0 * n / o.scored_frames) : "-";
    };
    const auto at = [](double m) {
      return m < 0 ? std::string("never") : fmt::format("{:.2f}", m);
    };
    out +=
        fmt::format("| {} | {} | {} | {} | {} | {} | {} | {} | {:.2f} | {} | {} | {} |\n", o.seed,
                    o.id, o.type, o.scored_frames, share(o.detected_frames), share(o.typed_frames),
                    at(o.first_detected_m), at(o.first_typed_m), o.farthest_scored_m, o.tracks,
                    o.id_switches, o.time_to_reach.count ? Pct(o.time_to_reach.median) : "-");
  }
  out += fmt::format(
      "\nTracks: {} reported, {} false ({:.2f} per minute), {} identity switches; time to reach "
      "|error| median {} %, p95 {} % ({} frames); approach rate |error| median {} %, p95 {} %. "
      "{} frames without a conductor model. {:.0f} s on {}.\n",
      reported_tracks, false_tracks, false_tracks_per_minute(), id_switches,
      Pct(time_to_reach.median), Pct(time_to_reach.p95), time_to_reach.count,
      Pct(approach_rate.median), Pct(approach_rate.p95), no_conductor_frames, elapsed_s, machine);
  return out;
}

nlohmann::json SequenceStudyReport::ToJson() const {
  nlohmann::json types_json = nlohmann::json::object();
  for (size_t t = 0; t < types.size(); ++t) types_json[types[t]] = by_type[t].ToJson();
  nlohmann::json bins_json = nlohmann::json::array();
  for (const SequenceBin& b : bins) {
    bins_json.push_back({{"from_m", b.from_m},
                         {"to_m", b.to_m},
                         {"rates", b.rates.ToJson()},
                         {"arc_relative_error", b.arc.ToJson()},
                         {"straight_relative_error", b.straight.ToJson()}});
  }
  nlohmann::json obstacles_json = nlohmann::json::array();
  for (const SequenceObstacle& o : obstacles) {
    obstacles_json.push_back({{"seed", o.seed},
                              {"id", o.id},
                              {"type", o.type},
                              {"scored_frames", o.scored_frames},
                              {"detected_frames", o.detected_frames},
                              {"typed_frames", o.typed_frames},
                              {"first_detected_m", o.first_detected_m},
                              {"first_typed_m", o.first_typed_m},
                              {"farthest_scored_m", o.farthest_scored_m},
                              {"tracks", o.tracks},
                              {"id_switches", o.id_switches},
                              {"time_to_reach_relative_error", o.time_to_reach.ToJson()}});
  }
  nlohmann::json out = {{"method", method},
                        {"calibration", calibration},
                        {"machine", machine},
                        {"command", command},
                        {"seeds", seeds},
                        {"tuning_seeds", tuning_seeds},
                        {"frames", frames},
                        {"frame_step", frame_step},
                        {"duration_s", duration_s},
                        {"speed_mps", speed_mps},
                        {"elapsed_s", elapsed_s},
                        {"ranging_settings", ranging_settings},
                        {"matcher_settings", matcher_settings},
                        {"by_type", types_json},
                        {"all", all.ToJson()},
                        {"arc_relative_error", arc.ToJson()},
                        {"straight_relative_error", straight.ToJson()},
                        {"bins", bins_json},
                        {"obstacles", obstacles_json},
                        {"tracks",
                         {{"reported", reported_tracks},
                          {"false", false_tracks},
                          {"false_per_minute", false_tracks_per_minute()},
                          {"id_switches", id_switches},
                          {"time_to_reach_relative_error", time_to_reach.ToJson()},
                          {"approach_rate_relative_error", approach_rate.ToJson()}}},
                        {"no_conductor_frames", no_conductor_frames}};
  if (estimated_calibration) {
    out["estimated_calibration"] = {{"views_rendered", estimated_calibration->views_rendered},
                                    {"views_used", estimated_calibration->views_used},
                                    {"rms_stereo_px", estimated_calibration->rms_stereo_px},
                                    {"baseline_m", estimated_calibration->baseline_m},
                                    {"true_baseline_m", estimated_calibration->true_baseline_m}};
  }
  return out;
}

void SequenceStudyReport::WritePlots(const fs::path& dir) const {
  fs::create_directories(dir);
  const double nan = std::nan("");
  std::vector<std::string> ticks;
  for (const SequenceBin& b : bins) ticks.push_back(fmt::format("{:.1f}-{:.1f}", b.from_m, b.to_m));
  LineChart recall{"Recall and precision vs distance along the line",
                   "along the line (m)",
                   "share",
                   ticks,
                   {},
                   {},
                   false};
  PlotSeries r{"recall", {}, false}, p{"precision", {}, true};
  for (const SequenceBin& b : bins) {
    r.y.push_back(b.rates.scored ? b.rates.recall() : nan);
    p.y.push_back(b.rates.detections ? b.rates.precision() : nan);
  }
  recall.series = {r, p};
  LineChart errors{"|Relative error| vs distance along the line",
                   "along the line (m)",
                   "%",
                   ticks,
                   {},
                   {},
                   false};
  PlotSeries am{"along the line, median", {}, false}, ap{"along the line, p95", {}, true},
      sm{"straight, median", {}, false}, sp{"straight, p95", {}, true};
  for (const SequenceBin& b : bins) {
    am.y.push_back(b.arc.count ? 100 * b.arc.median : nan);
    ap.y.push_back(b.arc.count ? 100 * b.arc.p95 : nan);
    sm.y.push_back(b.straight.count ? 100 * b.straight.median : nan);
    sp.y.push_back(b.straight.count ? 100 * b.straight.p95 : nan);
  }
  errors.series = {am, ap, sm, sp};
  // Every matched detection's error along the line, by type, against its truth arc (0.25 m
  // steps: the mean error of the detections in each step).
  LineChart per_type{"Error along the line by type (mean per 0.25 m)",
                     "along the line (m)",
                     "relative error %",
                     {},
                     {},
                     {},
                     false};
  const double lo = bins.empty() ? 0.5 : bins.front().from_m;
  const double hi = bins.empty() ? 5.0 : bins.back().to_m;
  const int steps = std::max(1, static_cast<int>(std::ceil((hi - lo) / 0.25)));
  for (int s = 0; s < steps; ++s) per_type.x_values.push_back(lo + 0.25 * (s + 0.5));
  for (size_t t = 0; t < types.size(); ++t) {
    std::vector<double> sum(steps, 0), n(steps, 0);
    for (const Sample& sample : samples) {
      if (sample.type != static_cast<int>(t)) continue;
      const int s = static_cast<int>((sample.truth_arc_m - lo) / 0.25);
      if (s < 0 || s >= steps) continue;
      sum[s] += 100 * sample.arc_error;
      n[s] += 1;
    }
    PlotSeries series{types[t], {}, false};
    for (int s = 0; s < steps; ++s) series.y.push_back(n[s] > 0 ? sum[s] / n[s] : nan);
    per_type.series.push_back(series);
  }
  WriteSvgPanels(dir / "sequences.svg", {recall, errors, per_type}, 3);
}

}  // namespace linesight
