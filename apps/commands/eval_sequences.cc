// linesight eval sequences: obstacle awareness on moving synthetic sequences - the conductor, the
// obstacles on it and their tracks, scored per frame against the truth
// (src/linesight/eval/sequence_study.h).
#include <fmt/format.h>
#include <fmt/ranges.h>

#include "cli.h"
#include "commands.h"
#include "linesight/core/error.h"
#include "linesight/core/progress.h"
#include "linesight/eval/sequence_study.h"
#include "linesight/ranging/ranging_settings.h"
#include "linesight/stereo/matcher.h"

namespace linesight::cli {

int RunEvalSequences(int argc, char** argv) {
  CLI::App app{
      "Obstacle awareness on moving synthetic power-line sequences: every frame is rectified, "
      "matched, searched for the conductor and the obstacles on it, tracked, and scored against "
      "the frame's truth (recall, precision and type accuracy per type, distance errors along "
      "the line and straight by distance, first detection, identity switches, time to reach).",
      "eval sequences"};
  SequenceStudyOptions options;
  std::vector<std::string> raw_params, ranging_settings;
  std::string json_path, markdown_path, plots_dir, calibration = "estimated";
  std::string command = "linesight eval";
  for (int i = 0; i < argc; ++i) command += fmt::format(" {}", argv[i]);
  app.add_option("--seeds", options.seeds, "sequence seeds to score")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--tuning-seeds", options.tuning_seeds,
                 "seeds the line stages were tuned on (the report flags any that is scored)")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--step", options.frame_step, "score every n-th frame")->capture_default_str();
  app.add_option("--max-frames", options.max_frames, "frames per sequence (0 = all)")
      ->capture_default_str();
  app.add_option("--calibration", calibration,
                 "true, or estimated (zhang on rendered board views, as on a real rig)")
      ->capture_default_str();
  app.add_option("--boards", options.boards, "board views for the estimated calibration")
      ->capture_default_str();
  app.add_option("--speed", options.sequence.speed_mps, "robot speed along the line (m/s)")
      ->capture_default_str();
  app.add_option("--fps", options.sequence.fps, "frame rate of the sequence (Hz)")
      ->capture_default_str();
  app.add_option("--obstacles", options.sequence.num_obstacles, "obstacles per sequence")
      ->capture_default_str();
  app.add_option("--supersampling", options.sequence.scene.sensor.supersampling,
                 "rays per pixel side of the renderer")
      ->capture_default_str();
  app.add_option("--min-arc", options.min_arc_m, "scored range along the line: from (m)")
      ->capture_default_str();
  app.add_option("--max-arc", options.max_arc_m, "scored range along the line: to (m)")
      ->capture_default_str();
  app.add_option("--bins", options.bin_edges, "distance bin edges along the line (m)")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--method", options.pipeline.method,
                 fmt::format("matcher: {} (default {})", fmt::join(MatcherNames(), ", "),
                             DefaultMatcherName()));
  AddParamOption(app, &raw_params);
  AddRangingSettingsOption(app, &ranging_settings);
  app.add_option("--threads", options.pipeline.threads, "matcher threads (0 = all cores)")
      ->capture_default_str();
  app.add_flag("--diagnose", options.diagnose,
               "print one line per missed truth and per detection that matches no truth to "
               "stderr: seed, frame, why, and the truths and detections whose boxes overlap it");
  app.add_option("--json", json_path, "JSON report (- for stdout)");
  app.add_option("--markdown", markdown_path, "also write the markdown tables to this file");
  app.add_option("--plots", plots_dir,
                 "write sequences.svg (recall / precision and errors vs distance) here");
  return RunCommand(app, argc, argv, [&] {
    options.calibration = ParseStudyCalibration(calibration);
    options.pipeline.params = ParseParams(raw_params);
    ApplyRangingSettings("--ranging", ranging_settings, &options.pipeline);
    options.Check();
    ProgressBar progress(SequenceStudyFrames(options), "eval sequences");
    SequenceStudyReport report = RunSequenceStudy(options, &progress);
    progress.Finish();
    report.command = command;
    EmitReport(report, json_path, markdown_path, plots_dir);
  });
}

}  // namespace linesight::cli
