#include "linesight/eval/fault_study.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <sstream>

#include <fmt/format.h>

#include "linesight/core/error.h"
#include "linesight/core/machine.h"
#include "linesight/core/progress.h"
#include "linesight/eval/plot.h"
#include "linesight/eval/study_sequences.h"
#include "linesight/geometry/depth.h"

namespace linesight {
namespace fs = std::filesystem;
namespace {

int IndexOf(const std::vector<std::string>& names, const std::string& name) {
  const auto it = std::find(names.begin(), names.end(), name);
  return it == names.end() ? -1 : static_cast<int>(it - names.begin());
}

int BinOf(const std::vector<double>& edges, double value) {
  for (size_t i = 0; i + 1 < edges.size(); ++i) {
    if (value >= edges[i] && value < edges[i + 1]) return static_cast<int>(i);
  }
  return value == edges.back() ? static_cast<int>(edges.size()) - 2 : -1;
}

// A scored truth of a frame: a defect of the line, or a damaged fitting (a tilted damper).
struct Truth {
  std::string type;  // DefectTypeName, or "damper_tilted"
  double arc_m = 0, arc_begin_m = 0, arc_end_m = 0;
  // What it is binned by: birdcage radius increase relative to the radius, a tilted damper's tilt
  // (deg), the rest in metres.
  double size = 0;
  int visible_pixels = 0;
};

// Whether the stretch [begin, end] of the line overlaps [truth_begin, truth_end] widened by margin.
bool Overlaps(double begin, double end, double truth_begin, double truth_end, double margin) {
  return end >= truth_begin - margin && begin <= truth_end + margin;
}

std::vector<Truth> TruthsOf(const sim::PowerLineScene& scene, double radius_m) {
  std::vector<Truth> truths;
  for (const sim::RenderedDefect& d : scene.defects) {
    truths.push_back({sim::DefectTypeName(d.type), d.arc_m, d.arc_begin_m, d.arc_end_m,
                      d.type == sim::DefectType::kBirdcage ? d.size_m / radius_m : d.size_m,
                      d.visible_pixels});
  }
  for (const sim::RenderedObstacle& o : scene.obstacles) {
    if (o.tilt_deg == 0) continue;
    const std::array<double, 2> extent = sim::ObstacleAlongExtent(o.type);
    truths.push_back({ConductorFaultTypeName(ConductorFaultType::kDamperTilted), o.arc_m,
                      o.arc_m + extent[0], o.arc_m + extent[1], std::fabs(o.tilt_deg),
                      o.visible_pixels});
  }
  return truths;
}

std::string Percent(const FaultRates& r) {
  return r.scored ? fmt::format("{:.2f} ({}/{})", r.recall(), r.matched, r.scored) : "-";
}

}  // namespace

FaultStudyOptions::FaultStudyOptions() {
  sequence.scene.sensor.supersampling = 2;
  sequence.num_defects = 4;
  sequence.tilted_damper_share = 0.5;
}

void FaultStudyOptions::Check() const {
  CheckOption(!seeds.empty(), "FaultStudyOptions.seeds", "empty", "needs at least one seed");
  CheckOption(frame_step >= 1 && frame_step <= 100, "FaultStudyOptions.frame_step", frame_step,
              "must be in [1, 100]");
  CheckOption(max_frames >= 0, "FaultStudyOptions.max_frames", max_frames, "must be >= 0");
  CheckOption(min_arc_m >= 0 && max_arc_m > min_arc_m, "FaultStudyOptions.max_arc_m", max_arc_m,
              "must exceed min_arc_m >= 0");
  CheckOption(bin_edges.size() >= 2 && std::is_sorted(bin_edges.begin(), bin_edges.end()),
              "FaultStudyOptions.bin_edges", bin_edges.size(), "needs >= 2 increasing edges");
  CheckOption(match_margin_m >= 0 && match_margin_m < 1, "FaultStudyOptions.match_margin_m",
              match_margin_m, "must be in [0, 1) m");
  sequence.Check();
  faults.Check();
  line.Check();
}

nlohmann::json FaultRates::ToJson() const {
  return {{"scored", scored},
          {"matched", matched},
          {"recall", recall()},
          {"typed_right", typed_right},
          {"type_accuracy", type_accuracy()}};
}

int FaultStudyFrames(const FaultStudyOptions& options) {
  int total = 0;
  for (std::uint64_t seed : options.seeds) {
    const int n = StudyFrames(options, StudySequence(options, seed));
    total += (n + options.frame_step - 1) / options.frame_step;
  }
  return total;
}

FaultStudyReport RunFaultStudy(const FaultStudyOptions& options, ProgressBar* progress) {
  options.Check();
  const auto start = std::chrono::steady_clock::now();
  FaultStudyReport report;
  report.seeds = options.seeds;
  report.tuning_seeds = options.tuning_seeds;
  report.frame_step = options.frame_step;
  report.machine = MachineDescription();
  report.bin_edges = options.bin_edges;
  for (sim::DefectType t : sim::AllDefectTypes()) report.types.push_back(sim::DefectTypeName(t));
  report.types.push_back(ConductorFaultTypeName(ConductorFaultType::kDamperTilted));
  report.by_type.resize(report.types.size());
  report.by_type_and_bin.assign(report.types.size(),
                                std::vector<FaultRates>(options.bin_edges.size() - 1));
  report.size_edges = {
      {"birdcage", {0.1, 0.2, 0.35, 0.5}},
      {"broken_strands", {0.003, 0.01, 0.025, 0.05}},
      {"string", {0.05, 0.2, 0.6}},
      {"sheet", {0.05, 0.15, 0.4}},
      {"nest", {0.15, 0.25, 0.4}},
      {ConductorFaultTypeName(ConductorFaultType::kDamperTilted), {10, 15, 20, 25}}};
  for (const auto& [name, edges] : report.size_edges) {
    report.by_size[name].resize(edges.size() - 1);
  }
  const double radius = options.sequence.scene.conductor_radius_m;
  const StereoCalibration calibration = sim::MakeStereoCalibration(options.sequence.scene.rig);
  RangingPipelineOptions pipeline_options = options.pipeline;
  pipeline_options.params = LineMatcherParams(pipeline_options.method, pipeline_options.params);
  const RangingPipeline pipeline(calibration, pipeline_options);
  const StereoGeometry geometry = GeometryFromCalibration(calibration);
  report.method = pipeline.method();
  std::vector<double> radius_errors;

  for (std::uint64_t seed : options.seeds) {
    const sim::PowerLineSequence sequence = StudySequence(options, seed);
    const int n = StudyFrames(options, sequence);
    ConductorModel previous;
    for (int index = 0; index < n; index += options.frame_step) {
      const sim::PowerLineScene scene = sequence.Render(index);
      const RangingFrame frame = pipeline.Process(scene.left, scene.right);
      const LineObstacles line =
          FindLineObstacles(pipeline, frame, options.line, previous.ok() ? &previous : nullptr);
      previous = line.conductor;
      const ConductorInspection inspection =
          InspectConductor(frame.left_rectified, frame.right_rectified, frame.checked_disparity,
                           line, geometry, options.faults);
      ++report.frames;
      report.no_conductor_frames += inspection.status == InspectionStatus::kNoConductor;
      report.not_inspected_frames += inspection.status == InspectionStatus::kNotInspected;
      if (inspection.status == InspectionStatus::kOk) {
        radius_errors.push_back(std::fabs(inspection.radius_m / radius - 1));
      }

      // Faults in the scored range, matched one to one to the scored truths, nearest first.
      std::vector<int> faults;
      for (size_t k = 0; k < inspection.faults.size(); ++k) {
        const ConductorFault& f = inspection.faults[k];
        if (f.arc_end_m >= options.min_arc_m && f.arc_begin_m <= options.max_arc_m) {
          faults.push_back(static_cast<int>(k));
        }
      }
      const std::vector<Truth> all_truths = TruthsOf(scene, radius);
      std::vector<int> truths;
      for (size_t t = 0; t < all_truths.size(); ++t) {
        const Truth& d = all_truths[t];
        if (d.arc_m >= options.min_arc_m && d.arc_m <= options.max_arc_m &&
            d.visible_pixels >= options.min_visible_pixels) {
          truths.push_back(static_cast<int>(t));
        }
      }
      struct Pair {
        double gap;
        int fault, truth;
      };
      std::vector<Pair> pairs;
      for (int k : faults) {
        const ConductorFault& f = inspection.faults[k];
        for (size_t t = 0; t < all_truths.size(); ++t) {
          const Truth& d = all_truths[t];
          if (Overlaps(f.arc_begin_m, f.arc_end_m, d.arc_begin_m, d.arc_end_m,
                       options.match_margin_m)) {
            pairs.push_back({std::fabs(f.arc_m - d.arc_m), k, static_cast<int>(t)});
          }
        }
      }
      std::sort(pairs.begin(), pairs.end(),
                [](const Pair& a, const Pair& b) { return a.gap < b.gap; });
      std::vector<int> fault_of_truth(all_truths.size(), -1);
      std::vector<char> fault_used(inspection.faults.size(), 0);
      for (const Pair& p : pairs) {
        if (fault_used[p.fault] || fault_of_truth[p.truth] >= 0) continue;
        fault_used[p.fault] = 1;
        fault_of_truth[p.truth] = p.fault;
      }
      for (int t : truths) {
        const Truth& d = all_truths[t];
        const std::string& type = d.type;
        const int k = fault_of_truth[t];
        const bool typed = k >= 0 && ConductorFaultTypeName(inspection.faults[k].type) == type;
        auto count = [&](FaultRates* r) {
          ++r->scored;
          r->matched += k >= 0;
          r->typed_right += typed;
        };
        const int ti = IndexOf(report.types, type);
        count(&report.all);
        count(&report.by_type[ti]);
        const int bin = BinOf(options.bin_edges, d.arc_m);
        if (bin >= 0) count(&report.by_type_and_bin[ti][bin]);
        const int size_bin = BinOf(report.size_edges[type], d.size);
        if (size_bin >= 0) count(&report.by_size[type][size_bin]);
      }
      // A fault that overlaps a truth (scored or not: one barely in view) is not a false alarm.
      for (int k : faults) {
        if (fault_used[k]) continue;
        const ConductorFault& f = inspection.faults[k];
        bool on_truth = false;
        for (const Truth& d : all_truths) {
          on_truth |= Overlaps(f.arc_begin_m, f.arc_end_m, d.arc_begin_m, d.arc_end_m,
                               options.match_margin_m);
        }
        if (on_truth) continue;
        ++report.false_alarms;
        ++report.false_alarms_by_type[ConductorFaultTypeName(f.type)];
      }
      // Clean conductor inspected in the scored range: measured samples' steps outside truths.
      for (size_t i = 1; i < inspection.profile.size(); ++i) {
        const RadiusSample& a = inspection.profile[i - 1];
        const RadiusSample& b = inspection.profile[i];
        if (!a.measured || !b.measured || b.arc_m < options.min_arc_m ||
            b.arc_m > options.max_arc_m) {
          continue;
        }
        bool on_truth = false;
        for (const sim::RenderedDefect& d : scene.defects) {
          on_truth |=
              Overlaps(b.arc_m, b.arc_m, d.arc_begin_m, d.arc_end_m, options.match_margin_m);
        }
        if (!on_truth) report.clean_inspected_m += std::fabs(b.arc_m - a.arc_m);
      }
      // The dampers' roll against their true tilt, and how often a sound one is flagged.
      for (const FittingState& state : inspection.fittings) {
        const LineObstacle& ob = line.obstacles[state.obstacle];
        if (!std::isfinite(state.roll_deg) || ob.arc_m < options.min_arc_m ||
            ob.arc_m > options.max_arc_m) {
          continue;
        }
        for (const sim::RenderedObstacle& o : scene.obstacles) {
          const std::array<double, 2> extent = sim::ObstacleAlongExtent(o.type);
          if (o.type != sim::ObstacleType::kDamper || ob.arc_m > o.arc_m + extent[1] ||
              ob.arc_m + ob.length_m < o.arc_m + extent[0]) {
            continue;
          }
          report.damper_roll_errors_deg.push_back(state.roll_deg - o.tilt_deg);
          if (o.tilt_deg == 0) {
            ++report.sound_damper_checks;
            report.sound_dampers_flagged +=
                std::fabs(state.roll_deg) >= options.faults.max_damper_roll_deg;
          }
          break;
        }
      }
      if (progress != nullptr) progress->Advance(1, fmt::format("seed {} frame {}", seed, index));
    }
  }
  if (!radius_errors.empty()) {
    std::nth_element(radius_errors.begin(), radius_errors.begin() + radius_errors.size() / 2,
                     radius_errors.end());
    report.radius_median_error = radius_errors[radius_errors.size() / 2];
  }
  report.elapsed_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return report;
}

double FaultStudyReport::RollErrorQuantile(double q) const {
  if (damper_roll_errors_deg.empty()) return 0.0;
  std::vector<double> e;
  for (double v : damper_roll_errors_deg) e.push_back(std::fabs(v));
  const size_t k = std::min(e.size() - 1, static_cast<size_t>(q * (e.size() - 1) + 0.5));
  std::nth_element(e.begin(), e.begin() + k, e.end());
  return e[k];
}

nlohmann::json FaultStudyReport::ToJson() const {
  nlohmann::json j = {{"method", method},
                      {"machine", machine},
                      {"command", command},
                      {"seeds", seeds},
                      {"tuning_seeds", tuning_seeds},
                      {"frames", frames},
                      {"frame_step", frame_step},
                      {"no_conductor_frames", no_conductor_frames},
                      {"not_inspected_frames", not_inspected_frames},
                      {"elapsed_s", elapsed_s},
                      {"bin_edges_m", bin_edges},
                      {"all", all.ToJson()},
                      {"false_alarms", false_alarms},
                      {"false_alarms_by_type", false_alarms_by_type},
                      {"clean_inspected_m", clean_inspected_m},
                      {"false_alarms_per_100m", false_alarms_per_100m()},
                      {"radius_median_error", radius_median_error},
                      {"damper_roll_checks", damper_roll_errors_deg.size()},
                      {"damper_roll_error_median_deg", RollErrorQuantile(0.5)},
                      {"damper_roll_error_p90_deg", RollErrorQuantile(0.9)},
                      {"sound_damper_checks", sound_damper_checks},
                      {"sound_dampers_flagged", sound_dampers_flagged}};
  for (size_t t = 0; t < types.size(); ++t) {
    nlohmann::json entry = by_type[t].ToJson();
    entry["by_distance"] = nlohmann::json::array();
    for (const FaultRates& r : by_type_and_bin[t]) entry["by_distance"].push_back(r.ToJson());
    entry["size_edges"] = size_edges.at(types[t]);
    entry["by_size"] = nlohmann::json::array();
    for (const FaultRates& r : by_size.at(types[t])) entry["by_size"].push_back(r.ToJson());
    j["types"][types[t]] = std::move(entry);
  }
  return j;
}

std::string FaultStudyReport::ToMarkdown() const {
  std::ostringstream out;
  out << "# Conductor faults on moving sequences\n\n";
  out << fmt::format(
      "Generated by `{}` on {} ({:.0f} s). Matcher {}. Seeds {} (tuning seeds: {}); "
      "{} frames (every {}), {} without a conductor model, {} not inspected.\n\n",
      command, machine, elapsed_s, method, fmt::join(seeds, ", "), fmt::join(tuning_seeds, ", "),
      frames, frame_step, no_conductor_frames, not_inspected_frames);
  bool overlap = false;
  for (auto s : seeds) {
    overlap |= std::find(tuning_seeds.begin(), tuning_seeds.end(), s) != tuning_seeds.end();
  }
  if (overlap) out << "**Warning: scored seeds include tuning seeds.**\n\n";
  out << "Recall per frame (matched / scored truths) by the truth's distance along the line, and "
         "type accuracy of the matched:\n\n| type |";
  for (size_t b = 0; b + 1 < bin_edges.size(); ++b) {
    out << fmt::format(" {:.1f}-{:.1f} m |", bin_edges[b], bin_edges[b + 1]);
  }
  out << " all | type accuracy |\n|---|";
  for (size_t b = 0; b + 1 < bin_edges.size(); ++b) out << "---|";
  out << "---|---|\n";
  for (size_t t = 0; t < types.size(); ++t) {
    out << "| " << types[t] << " |";
    for (const FaultRates& r : by_type_and_bin[t]) out << " " << Percent(r) << " |";
    out << " " << Percent(by_type[t]) << " | "
        << (by_type[t].matched ? fmt::format("{:.2f}", by_type[t].type_accuracy()) : "-") << " |\n";
  }
  out << fmt::format("| all | | | | {} | {:.2f} |\n\n", Percent(all), all.type_accuracy());
  out << "Recall by size (birdcage: radius increase relative to the radius; damper_tilted: tilt in "
         "deg; the others in m):\n\n";
  for (const std::string& type : types) {
    const std::vector<double>& edges = size_edges.at(type);
    out << "- " << type << ":";
    for (size_t b = 0; b + 1 < edges.size(); ++b) {
      out << fmt::format(" {}-{}: {};", edges[b], edges[b + 1], Percent(by_size.at(type)[b]));
    }
    out << "\n";
  }
  out << fmt::format(
      "\nFalse alarms: {} over {:.1f} m of clean conductor inspected (summed over frames): {:.2f} "
      "per 100 m",
      false_alarms, clean_inspected_m, false_alarms_per_100m());
  if (!false_alarms_by_type.empty()) {
    std::vector<std::string> parts;
    for (const auto& [type, count] : false_alarms_by_type) {
      parts.push_back(fmt::format("{} {}", type, count));
    }
    out << " (" << fmt::format("{}", fmt::join(parts, ", ")) << ")";
  }
  out << fmt::format(".\n\nConductor radius from the image edges: median |error| {:.1f} %.\n",
                     100 * radius_median_error);
  if (!damper_roll_errors_deg.empty()) {
    out << fmt::format(
        "\nDampers' roll about the line against their true tilt: |error| median {:.1f} deg, 90th "
        "percentile {:.1f} deg over {} checks; sound dampers flagged as tilted: {} of {} checks.\n",
        RollErrorQuantile(0.5), RollErrorQuantile(0.9), damper_roll_errors_deg.size(),
        sound_dampers_flagged, sound_damper_checks);
  }
  return out.str();
}

void FaultStudyReport::WritePlots(const fs::path& dir) const {
  fs::create_directories(dir);
  std::vector<std::string> ticks;
  for (size_t b = 0; b + 1 < bin_edges.size(); ++b) {
    ticks.push_back(fmt::format("{:.1f}-{:.1f}", bin_edges[b], bin_edges[b + 1]));
  }
  LineChart chart{"Fault recall vs distance along the line",
                  "along the line (m)",
                  "recall",
                  ticks,
                  {},
                  {},
                  false};
  for (size_t t = 0; t < types.size(); ++t) {
    PlotSeries s{types[t], {}, false};
    for (const FaultRates& r : by_type_and_bin[t]) {
      s.y.push_back(r.scored ? r.recall() : std::nan(""));
    }
    chart.series.push_back(s);
  }
  WriteSvg(dir / "faults.svg", chart);
}

}  // namespace linesight
