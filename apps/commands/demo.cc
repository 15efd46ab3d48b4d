// linesight demo: the whole chain on the embedded synthetic power-line scene.
#include <cstdio>
#include <iostream>

#include <fmt/format.h>

#include "cli.h"
#include "commands.h"
#include "linesight/core/timer.h"
#include "linesight/demo/demo.h"
#include "linesight/io/json_io.h"
#include "linesight/stereo/matcher.h"

namespace linesight::cli {

int RunDemo(int argc, char** argv) {
  CLI::App app{
      "Render the synthetic power-line scene and calibration boards, calibrate, rectify, match, "
      "range "
      "every obstacle and print true vs measured distance.",
      "demo"};
  DemoOptions options;
  std::string out_dir = options.out_dir.string(), obstacles_text, json_path;
  app.add_option("--out", out_dir, "output folder (images, stereo.yml, cloud.ply, report.json)")
      ->capture_default_str();
  app.add_option("--seed", options.seed, "scene and board seed")->capture_default_str();
  app.add_option("--obstacles", obstacles_text,
                 "obstacles as type:distance_m,... (types: damper, clamp, insulator); default "
                 "damper:1.5,clamp:3,insulator:4.5");
  app.add_option("--method", options.method, "matcher (default: " + DefaultMatcherName() + ")");
  app.add_option("--calibration", options.calibration_method,
                 "calibration method: zhang, recon, opencv")
      ->capture_default_str();
  app.add_option("--board-views", options.board_views, "rendered calibration views")
      ->capture_default_str();
  app.add_flag("--true-calibration", options.use_true_calibration,
               "skip calibration and use the renderer's true calibration");
  app.add_option("--min-depth", options.min_depth_m, "working range, nearest depth (m)")
      ->capture_default_str();
  app.add_option("--max-depth", options.max_depth_m, "working range, farthest depth (m)")
      ->capture_default_str();
  app.add_option("--threads", options.threads, "matcher threads (0 = all cores)")
      ->capture_default_str();
  app.add_option("--json", json_path, "also write the report here (- for stdout)");
  return RunCommand(app, argc, argv, [&] {
    options.out_dir = out_dir;
    if (!obstacles_text.empty()) options.obstacles = sim::ParseObstacleSpecs(obstacles_text);
    Stopwatch watch;
    std::fprintf(stderr, "linesight demo -> %s\n", out_dir.c_str());
    const DemoReport report = linesight::RunDemo(options, stderr);
    TableStream(json_path) << "\n" << report.Table() << std::flush;
    std::fprintf(
        stderr,
        "\nwrote %s/{left,right,rectified_left_ranged,disparity}.png, disparity.pfm, cloud.ply, "
        "stereo.yml, report.json, scene/%s in %.1f s\n",
        out_dir.c_str(), options.use_true_calibration ? "" : ", boards/", watch.ElapsedMs() / 1000);
    if (!json_path.empty()) WriteJson(json_path, report.json);
  });
}

}  // namespace linesight::cli
