// linesight eval obstacles: matchers on rendered power-line obstacle crops
// (src/linesight/eval/obstacle_images.h).
#include <filesystem>
#include <iostream>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "cli.h"
#include "commands.h"
#include "linesight/core/atomic_file.h"
#include "linesight/core/progress.h"
#include "linesight/eval/obstacle_images.h"
#include "linesight/io/json_io.h"
#include "linesight/stereo/matcher.h"

namespace linesight::cli {

int RunEvalObstacles(int argc, char** argv) {
  CLI::App app{
      "Render the synthetic power-line scene (ideal rectified pair, exact ground truth), crop "
      "each obstacle (damper, clamp, insulator string) with a margin and score the matchers on "
      "the obstacle pixels and on the whole crop, clean and with image noise.",
      "eval obstacles"};
  EvalObstaclesOptions options;
  ObstacleImageOptions images;
  std::string obstacles_text = "damper:1.5,clamp:3,insulator:4.5", json_path, markdown_path,
              plots_dir;
  std::vector<std::string> noise_texts = {"clean"};
  std::vector<std::string> raw_params;
  app.add_option("--methods", options.methods,
                 fmt::format("methods, comma-separated: {}", fmt::join(MatcherNames(), ", ")))
      ->delimiter(',')
      ->capture_default_str();
  AddParamOption(app, &raw_params);
  app.add_option("--obstacles", obstacles_text,
                 "obstacles of the scene: type:distance_m[:conductor], comma-separated (types "
                 "damper, clamp, insulator)")
      ->capture_default_str();
  app.add_option("--noise", noise_texts,
                 "noise settings, comma-separated: clean, gauss:VARIANCE, sp:DENSITY")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--seed", images.seed, "scene seed")->capture_default_str();
  app.add_option("--supersampling", images.supersampling, "anti-aliasing rays per pixel side")
      ->capture_default_str();
  app.add_option("--margin", images.margin_px, "margin around each obstacle box (px)")
      ->capture_default_str();
  app.add_option("--threads", options.threads, "matcher threads (0 = all cores)")
      ->capture_default_str();
  app.add_option("--json", json_path, "JSON report (- for stdout)");
  app.add_option("--markdown", markdown_path, "also write the markdown tables to this file");
  app.add_option("--plots", plots_dir, "write obstacles_noise.svg here (several noise settings)");
  return RunCommand(app, argc, argv, [&] {
    images.obstacles = sim::ParseObstacleSpecs(obstacles_text);
    options.params = ParseParams(raw_params);
    options.noise.clear();
    for (const std::string& text : noise_texts) options.noise.push_back(NoiseSpec::Parse(text));
    options.Check();
    const std::vector<StereoScene> scenes = RenderObstacleScenes(images);
    ProgressBar progress(
        static_cast<int64_t>(scenes.size() * options.methods.size() * options.noise.size()),
        "eval obstacles");
    const EvalObstaclesReport report = RunEvalObstacles(scenes, options, &progress);
    progress.Finish();
    EmitReport(report, json_path, markdown_path, plots_dir);
  });
}

}  // namespace linesight::cli
