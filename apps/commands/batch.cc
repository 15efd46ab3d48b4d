// linesight batch: disparity / ranging of many recorded pairs in one process (ranging/batch.h).
#include <cstdlib>
#include <filesystem>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "cli.h"
#include "commands.h"
#include "linesight/core/error.h"
#include "linesight/ranging/batch.h"
#include "linesight/ranging/ranging_settings.h"

namespace linesight::cli {

int RunBatch(int argc, char** argv) {
  CLI::App app{
      "Disparity (and, with --calib, automatic ranging) of every pair of a manifest in one "
      "process. Pairs whose outputs exist are skipped, so an interrupted batch resumes; --shard "
      "(or a Slurm array task's environment) processes one shard, --merge joins the shards' "
      "summaries.",
      "batch"};
  std::string manifest_path, left_glob, right_glob, out_dir, calib_path, shard_text;
  std::vector<std::string> raw_params, ranging_settings;
  bool merge = false;
  BatchOptions options;
  auto* manifest = app.add_option(
      "--manifest", manifest_path,
      "pairs, one per line: <left> <right> [<name>] (# comments; paths relative to the "
      "manifest's folder)");
  auto* left = app.add_option("--left", left_glob,
                              "instead of --manifest: left images, a glob (quote it), paired in "
                              "sorted order with --right's");
  auto* right = app.add_option("--right", right_glob, "right images, a glob");
  manifest->excludes(left)->excludes(right);
  left->needs(right);
  right->needs(left);
  app.add_option("--out", out_dir, "output folder: <name>.pfm, <name>.json, summary*.json")
      ->required();
  app.add_option("--calib", calib_path,
                 "stereo calibration: the pairs are raw; rectify, match the working range and "
                 "find the obstacles (as `range --auto`)");
  app.add_flag("--rectified", options.ranging.input_rectified,
               "with --calib: the pairs are already rectified (P1 P2 Q as given)");
  app.add_option("--method", options.method,
                 fmt::format("matcher: {} (default {})", fmt::join(MatcherNames(), ", "),
                             DefaultMatcherName()));
  app.add_option("--min-disp", options.matcher.min_disparity,
                 "without --calib: smallest disparity searched (px)")
      ->capture_default_str();
  app.add_option("--num-disp", options.matcher.num_disparities,
                 "without --calib: number of disparities searched")
      ->capture_default_str();
  app.add_option("--min-depth", options.ranging.min_depth_m,
                 "with --calib: working range, nearest depth (m)")
      ->capture_default_str();
  app.add_option("--max-depth", options.ranging.max_depth_m,
                 "with --calib: working range, farthest depth (m)")
      ->capture_default_str();
  app.add_option("--threads", options.matcher.threads, "matcher threads (0 = all cores)")
      ->capture_default_str();
  AddParamOption(app, &raw_params);
  AddRangingSettingsOption(app, &ranging_settings);
  app.add_option("--shard", shard_text,
                 "process shard I of N (pairs i with i mod N = I), e.g. 0/4; default: the Slurm "
                 "array task (SLURM_ARRAY_TASK_ID of SLURM_ARRAY_TASK_COUNT), else all pairs");
  app.add_flag("--merge", merge,
               "merge the shard summaries in --out into summary.json (processes nothing)");
  return RunCommand(app, argc, argv, [&] {
    if (manifest_path.empty() && left_glob.empty()) {
      throw UsageError("give --manifest FILE, or --left and --right globs");
    }
    const std::vector<BatchPair> pairs = manifest_path.empty()
                                             ? BatchPairsFromGlobs(left_glob, right_glob)
                                             : ReadBatchManifest(manifest_path);
    options.out = out_dir;
    if (merge) {
      const nlohmann::json summary = MergeBatchSummaries(pairs, options.out);
      std::fprintf(stderr, "batch: merged %d shards: %d done, %d skipped, %d failed, %d missing\n",
                   summary["merged_shards"].get<int>(), summary["done"].get<int>(),
                   summary["skipped"].get<int>(), summary["failed"].get<int>(),
                   summary["missing"].get<int>());
      if (summary["failed"].get<int>() + summary["missing"].get<int>() > 0) {
        throw InputError(fmt::format("{} pair(s) failed or have no outputs: see {}/summary.json",
                                     summary["failed"].get<int>() + summary["missing"].get<int>(),
                                     out_dir));
      }
      return;
    }
    if (!shard_text.empty()) {
      options.shard = ParseBatchShard(shard_text);
    } else if (auto slurm = BatchShardFromSlurm(std::getenv)) {
      options.shard = *slurm;
    }
    const auto params = ParseParams(raw_params);
    if (!calib_path.empty()) {
      ApplyRangingSettings("--ranging", ranging_settings, &options.ranging);
      options.ranging.method = options.method;
      options.ranging.params = params;
      options.ranging.threads = options.matcher.threads;
      options.calibration = ReadStereoCalibration(calib_path);
      options.calibration_path = calib_path;
    } else {
      if (!ranging_settings.empty() || options.ranging.input_rectified) {
        throw UsageError("--ranging and --rectified need --calib (ranging)");
      }
      options.matcher.params = params;
    }
    const nlohmann::json summary = RunBatch(pairs, options, [](const nlohmann::json& entry) {
      if (entry["status"] == "failed") {
        std::fprintf(stderr, "batch: %s failed: %s\n", entry["name"].get<std::string>().c_str(),
                     entry["error"].get<std::string>().c_str());
      }
    });
    std::fprintf(stderr, "batch: shard %d/%d, %zu pairs: %d done, %d skipped, %d failed, %.1f s\n",
                 options.shard.index, options.shard.count, summary["pairs"].size(),
                 summary["done"].get<int>(), summary["skipped"].get<int>(),
                 summary["failed"].get<int>(), summary["seconds"].get<double>());
    if (summary["failed"].get<int>() > 0) {
      throw InputError(fmt::format("{} pair(s) failed: see {}", summary["failed"].get<int>(),
                                   BatchSummaryPath(options.out, options.shard).string()));
    }
  });
}

}  // namespace linesight::cli
