// linesight eval faults: conductor faults on moving synthetic sequences with seeded defects - the
// conductor, its fittings and the inspection, scored per frame against the defects' truth
// (src/linesight/eval/fault_study.h).
#include <fmt/format.h>
#include <fmt/ranges.h>

#include "cli.h"
#include "commands.h"
#include "linesight/core/error.h"
#include "linesight/core/progress.h"
#include "linesight/eval/fault_study.h"
#include "linesight/stereo/matcher.h"

namespace linesight::cli {

int RunEvalFaults(int argc, char** argv) {
  CLI::App app{
      "Conductor faults on moving synthetic power-line sequences with seeded defects (bird-caging, "
      "broken strands, string, sheet, nest): every scored frame is rectified, matched, searched "
      "for the conductor and its fittings, inspected (linesight inspect), and scored against the "
      "frame's truth (recall per defect type by distance and size, type accuracy, false alarms "
      "per 100 m of clean conductor, the radius's error).",
      "eval faults"};
  FaultStudyOptions options;
  std::vector<std::string> raw_params;
  std::string json_path, markdown_path, plots_dir;
  std::string command = "linesight eval";
  for (int i = 0; i < argc; ++i) command += fmt::format(" {}", argv[i]);
  app.add_option("--seeds", options.seeds, "sequence seeds to score")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--tuning-seeds", options.tuning_seeds,
                 "seeds the inspection was tuned on (the report flags any that is scored)")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--step", options.frame_step, "score every n-th frame")->capture_default_str();
  app.add_option("--max-frames", options.max_frames, "frames per sequence (0 = all)")
      ->capture_default_str();
  app.add_option("--defects", options.sequence.num_defects, "defects per sequence")
      ->capture_default_str();
  app.add_option("--tilted-dampers", options.sequence.tilted_damper_share,
                 "share of the dampers turned about the line by 10..25 deg")
      ->capture_default_str();
  app.add_option("--supersampling", options.sequence.scene.sensor.supersampling,
                 "rays per pixel side of the renderer")
      ->capture_default_str();
  app.add_option("--min-arc", options.min_arc_m, "scored range along the line: from (m)")
      ->capture_default_str();
  app.add_option("--max-arc", options.max_arc_m, "scored range along the line: to (m)")
      ->capture_default_str();
  app.add_option("--method", options.pipeline.method,
                 fmt::format("matcher: {} (default {})", fmt::join(MatcherNames(), ", "),
                             DefaultMatcherName()));
  AddParamOption(app, &raw_params);
  app.add_option("--threads", options.pipeline.threads, "matcher threads (0 = all cores)")
      ->capture_default_str();
  app.add_option("--json", json_path, "JSON report (- for stdout)");
  app.add_option("--markdown", markdown_path, "also write the markdown tables to this file");
  app.add_option("--plots", plots_dir, "write faults.svg (recall vs distance per type) here");
  return RunCommand(app, argc, argv, [&] {
    options.pipeline.params = ParseParams(raw_params);
    options.faults.max_arc_m = std::max(options.faults.max_arc_m, options.max_arc_m + 0.5);
    options.Check();
    ProgressBar progress(FaultStudyFrames(options), "eval faults");
    FaultStudyReport report = RunFaultStudy(options, &progress);
    progress.Finish();
    report.command = command;
    EmitReport(report, json_path, markdown_path, plots_dir);
  });
}

}  // namespace linesight::cli
