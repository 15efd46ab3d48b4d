// linesight bench: end-to-end throughput of sgm / isgm against OpenCV StereoSGBM in the same run.
#include <cstdio>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "cli.h"
#include "commands.h"
#include "linesight/core/error.h"
#include "linesight/io/image_io.h"
#include "linesight/io/json_io.h"
#include "linesight/io/stereo_calibration.h"
#include "linesight/server/chain_bench.h"
#include "linesight/sim/power_line_scene.h"
#include "linesight/stereo/throughput_bench.h"

namespace linesight::cli {

int RunBench(int argc, char** argv) {
  CLI::App app{
      "Throughput (ms, fps, MDE/s, peak memory) of dense matchers on the same images in one run: "
      "sgm, isgm and OpenCV StereoSGBM (sgbm-3way = MODE_SGBM_3WAY, sgbm-hh = MODE_HH).",
      "bench"};
  BenchOptions options;
  std::vector<std::string> sizes = {"752x480x128", "752x480x192", "1242x375x128"};
  std::string left_path, right_path, json_path;
  app.add_option("--sizes", sizes, "WIDTHxHEIGHTxDISPARITIES list (comma-separated)")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option(
         "--methods", options.methods,
         "matcher names (any of the factory's, plus sgbm-3way and sgbm-hh), each optionally "
         "with --param settings as NAME:key=value[:key=value...] (e.g. isgm:paths=8); "
         "unknown names are skipped; ratios are against the row named sgbm-3way")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--runs", options.runs, "timed runs per method, size and round")
      ->capture_default_str();
  app.add_option("--rounds", options.rounds,
                 "rounds over the method list (methods interleaved; medians pooled)")
      ->capture_default_str();
  app.add_option("--warmup", options.warmup, "untimed warm-up runs (discarded)")
      ->capture_default_str();
  app.add_option("--threads", options.threads, "worker threads for every method (0 = all cores)")
      ->capture_default_str();
  app.add_option("--left", left_path,
                 "left image to resize to each size (default: synthetic textured pair)");
  app.add_option("--right", right_path, "right image (with --left)");
  app.add_option("--json", json_path, "machine-readable report (- for stdout)");
  bool chain = false;
  ChainBenchOptions chain_options;
  std::string calib_path, finder = "line";
  app.add_flag(
      "--chain", chain,
      "measure the live chain instead (what serve does per frame: grab, rectify, match, "
      "find and range, inspect, encode) on the demo's scene, or on --left/--right with --calib; "
      "default methods isgm,sgm,sgbm, ratios against sgbm through the same chain");
  app.add_option("--calib", calib_path, "--chain: calibration of --left/--right");
  app.add_option("--frames", chain_options.frames, "--chain: timed frames per method")
      ->capture_default_str();
  app.add_option("--finder", finder, "--chain: line or regions")->capture_default_str();
  app.add_option("--min-depth", chain_options.station.pipeline.min_depth_m,
                 "--chain: working range, nearest depth (m)")
      ->capture_default_str();
  app.add_option("--max-depth", chain_options.station.pipeline.max_depth_m,
                 "--chain: working range, farthest depth (m)")
      ->capture_default_str();
  return RunCommand(app, argc, argv, [&] {
    if (chain) {
      if (app.count("--methods")) chain_options.methods = options.methods;
      if (app.count("--warmup")) chain_options.warmup = options.warmup;
      chain_options.station.pipeline.threads = options.threads;
      chain_options.station.finder = ParseAutoFinder(finder);
      cv::Mat left, right;
      StereoCalibration calibration;
      std::string input;
      if (left_path.empty() != right_path.empty() || left_path.empty() != calib_path.empty()) {
        throw UsageError("--chain takes --left, --right and --calib together, or none of them");
      }
      if (left_path.empty()) {
        const sim::PowerLineScene scene = sim::RenderPowerLineScene(sim::PowerLineSceneOptions{});
        left = scene.left;
        right = scene.right;
        calibration = scene.calibration;
        input = "the demo's scene";
      } else {
        left = ReadImage(left_path, ImageColor::kColor);
        right = ReadImage(right_path, ImageColor::kColor);
        calibration = ReadStereoCalibration(calib_path);
        input = left_path;
      }
      const ChainBenchReport report =
          RunChainBench(left, right, calibration, input, chain_options, [](const ChainBenchRow& r) {
            std::fprintf(stderr, "bench --chain: %s %.1f ms per frame\n", r.method.c_str(),
                         r.frame_ms);
          });
      if (json_path != "-") std::fputs(ChainBenchMarkdown(report).c_str(), stdout);
      if (!json_path.empty()) WriteJson(json_path, ChainBenchJson(report));
      return;
    }
    options.sizes.clear();
    for (const std::string& s : sizes) options.sizes.push_back(ParseBenchSize(s));
    if (left_path.empty() != right_path.empty()) throw UsageError("--left and --right go together");
    if (!left_path.empty()) {
      options.left = ReadImage(left_path, ImageColor::kGray);
      options.right = ReadImage(right_path, ImageColor::kGray);
      if (options.left.size() != options.right.size()) {
        throw InputError(fmt::format("{} is {}x{} but {} is {}x{}", left_path, options.left.cols,
                                     options.left.rows, right_path, options.right.cols,
                                     options.right.rows));
      }
    }
    const BenchReport report = RunThroughputBench(options, [](const BenchRow& row) {
      std::fprintf(stderr, "bench: %s %dx%dx%d %s\n", row.method.c_str(), row.size.width,
                   row.size.height, row.size.num_disparities,
                   row.skipped ? ("skipped: " + row.note).c_str()
                               : fmt::format("{:.1f} ms", row.median_ms).c_str());
    });
    if (json_path != "-") std::fputs(BenchMarkdown(report).c_str(), stdout);
    if (!json_path.empty()) WriteJson(json_path, BenchJson(report));
  });
}

}  // namespace linesight::cli
