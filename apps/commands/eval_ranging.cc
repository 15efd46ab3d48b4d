// linesight eval ranging: the ranging accuracy study on rendered power-line scenes (true and
// estimated calibration) plus the metric depth check on Middlebury 2014 Motorcycle,
// src/linesight/eval/ranging_study.h.
#include <cstdio>
#include <iostream>

#include <fmt/format.h>

#include "cli.h"
#include "commands.h"
#include "linesight/core/atomic_file.h"
#include "linesight/core/progress.h"
#include "linesight/eval/ranging_study.h"
#include "linesight/eval/real_ranging.h"
#include "linesight/io/json_io.h"
#include "linesight/ranging/ranging_settings.h"
#include "linesight/stereo/matcher.h"

namespace linesight::cli {

int RunEvalRanging(int argc, char** argv) {
  CLI::App app{
      "Ranging accuracy study on rendered power-line scenes (true and estimated calibration) and "
      "the metric depth check on Middlebury 2014 Motorcycle.",
      "eval ranging"};
  RangingStudyOptions options;
  std::vector<std::string> type_texts{"damper", "clamp", "insulator"},
      calibration_texts{"true", "estimated"}, raw_params, ranging_settings;
  std::string json_path, plot_path, markdown_path, middlebury_dir = options.middlebury_dir;
  app.add_option("--runs", options.runs,
                 "measurements per type and distance (fresh sensor noise each)")
      ->capture_default_str();
  app.add_option("--distances", options.distances, "true distances (m), comma separated")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--types", type_texts, "obstacle types: damper, clamp, insulator")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--calibrations", calibration_texts,
                 "true and/or estimated (from rendered boards)")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--boards", options.boards, "rendered board views for the estimated calibration")
      ->capture_default_str();
  app.add_option("--seed", options.seed, "scene seed")->capture_default_str();
  app.add_option("--noise", options.noise_dn, "sensor read noise (DN)")->capture_default_str();
  AddLineGeometryOptions(app, &options.conductor_offset_x_m, &options.conductor_offset_y_m,
                         &options.conductor_yaw_rad, &options.tower_offset_x_m);
  app.add_option("--supersampling", options.supersampling, "renderer supersampling per axis")
      ->capture_default_str();
  app.add_option("--method", options.pipeline.method,
                 fmt::format("matcher (default {})", DefaultMatcherName()));
  AddParamOption(app, &raw_params);
  app.add_option("--min-depth", options.pipeline.min_depth_m, "working range (m)")
      ->capture_default_str();
  app.add_option("--max-depth", options.pipeline.max_depth_m, "working range (m)")
      ->capture_default_str();
  app.add_option("--threads", options.pipeline.threads, "matcher threads (0 = all)")
      ->capture_default_str();
  app.add_option("--middlebury", middlebury_dir, "Middlebury 2014 scene folder ('' to skip)")
      ->capture_default_str();
  AddRangingSettingsOption(app, &ranging_settings);
  std::string real_root;
  app.add_option("--real", real_root,
                 "instead of the rendered scenes: range regions derived from the ground truth of "
                 "every real pair with a metric calibration under this folder (Middlebury 2014, "
                 "2005/2006 half size, ETH3D), e.g. " LINESIGHT_SHARED_DATA_DIR);
  app.add_option("--json", json_path, "report (- for stdout)");
  app.add_option("--plot", plot_path, "SVG plot of relative error vs distance");
  app.add_option("--markdown", markdown_path, "write the table as Markdown too");
  app.add_flag("--diagnose", options.diagnose,
               "print one line per run and calibration to stderr: truth, measured, the same "
               "estimator on the ground-truth disparity, and the matcher's disparity error on the "
               "obstacle's nearest-surface pixels, and the calibration's own depth error at the "
               "nearest point (for finding a cell's bias); with --real one line per region: "
               "measured, the estimator on the ground truth, the reading with thin structures "
               "kept, the matcher's median error over the ROI");
  return RunCommand(app, argc, argv, [&] {
    options.pipeline.params = ParseParams(raw_params);
    ApplyRangingSettings("--ranging", ranging_settings, &options.pipeline);
    if (!real_root.empty()) {
      RealRangingOptions real;
      real.root = real_root;
      real.pipeline = options.pipeline;
      real.diagnose = options.diagnose;
      ProgressBar progress(static_cast<int64_t>(MetricScenes(real.root).size()),
                           "eval ranging --real");
      const RealRangingReport report = RunRealRangingStudy(real, &progress);
      std::ostream& out = TableStream(json_path);
      out << report.ToMarkdown();
      std::fprintf(stderr, "%zu regions of %zu scenes in %.1f s\n", report.regions.size(),
                   report.scenes.size(), report.elapsed_s);
      if (!markdown_path.empty()) WriteTextAtomic(markdown_path, report.ToMarkdown());
      if (!plot_path.empty()) WriteTextAtomic(plot_path, report.ToSvg());
      if (!json_path.empty()) WriteJson(json_path, report.ToJson());
      return;
    }
    options.types.clear();
    for (const std::string& t : type_texts) options.types.push_back(sim::ParseObstacleType(t));
    options.calibrations.clear();
    for (const std::string& c : calibration_texts) {
      options.calibrations.push_back(ParseStudyCalibration(c));
    }
    options.middlebury_dir = middlebury_dir;
    options.Check();
    ProgressBar progress(
        static_cast<int64_t>(options.types.size() * options.distances.size()) * options.runs,
        "eval ranging");
    const RangingStudyReport report = RunRangingStudy(options, &progress, stderr);
    std::ostream& out = TableStream(json_path);
    out << report.ToMarkdown();
    std::fprintf(stderr, "%d scenes in %.1f s\n", report.scenes, report.scenes_seconds);
    out << report.MiddleburySummary();
    if (!markdown_path.empty()) WriteTextAtomic(markdown_path, report.ToMarkdown());
    if (!plot_path.empty()) WriteTextAtomic(plot_path, report.ToSvg());
    if (!json_path.empty()) WriteJson(json_path, report.ToJson());
  });
}

}  // namespace linesight::cli
