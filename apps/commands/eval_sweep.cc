// linesight eval sweep: one-at-a-time parameter study (src/linesight/eval/sweep.h).
#include <algorithm>
#include <filesystem>
#include <iostream>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "cli.h"
#include "commands.h"
#include "linesight/core/atomic_file.h"
#include "linesight/core/error.h"
#include "linesight/core/progress.h"
#include "linesight/eval/sweep.h"
#include "linesight/io/json_io.h"

namespace linesight::cli {

int RunEvalSweep(int argc, char** argv) {
  CLI::App app{
      "Parameter study: vary one parameter at a time around the centre point (SGBM family: "
      "num-disp 16..112, block 3..11, uniqueness 5..15 around 64/7/10; isgm: num-disp, p1, p2, "
      "superpixel_size, plane_inlier around its defaults) and report RMSE and the headline "
      "bad-pixel rate averaged over the scenes.",
      "eval sweep"};
  std::string data_dir, json_path, markdown_path, plots_dir;
  std::vector<std::string> sets = {"middlebury-2001-2003"};
  std::vector<std::string> methods = {"sgbm", "sgbm-wls", "isgm"};
  int max_scenes = 0, threads = 0;
  app.add_option("--data", data_dir, "folder holding benchmark scenes (searched recursively)")
      ->required();
  app.add_option("--sets", sets,
                 "sets (folder names) to average over, comma-separated; all = every set")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--methods", methods,
                 fmt::format("methods with a defined study: {}",
                             fmt::join(MethodsWithDefaultSweep(), ", ")))
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--max-scenes", max_scenes, "use at most this many scenes (0 = all)")
      ->capture_default_str();
  app.add_option("--threads", threads, "matcher threads (0 = all cores)")->capture_default_str();
  app.add_option("--json", json_path, "JSON report (- for stdout)");
  app.add_option("--markdown", markdown_path, "also write the markdown tables to this file");
  app.add_option("--plots", plots_dir, "write sweep_rmse.svg and sweep_bad.svg here");
  return RunCommand(app, argc, argv, [&] {
    if (max_scenes < 0) throw UsageError(fmt::format("--max-scenes {} must be >= 0", max_scenes));
    std::vector<SceneRef> scenes = FindScenes(data_dir);
    if (std::find(sets.begin(), sets.end(), "all") == sets.end()) {
      std::erase_if(scenes, [&](const SceneRef& s) {
        return std::find(sets.begin(), sets.end(), s.set) == sets.end();
      });
    }
    if (scenes.empty()) {
      throw InputError(
          fmt::format("{}: no benchmark scenes of the sets {}", data_dir, fmt::join(sets, ",")));
    }
    if (max_scenes > 0 && scenes.size() > static_cast<size_t>(max_scenes)) {
      scenes.resize(max_scenes);
    }
    SweepOptions options;
    options.methods = methods;
    options.threads = threads;
    ProgressBar progress(SweepSteps(options, scenes.size()), "eval sweep");
    const SweepReport report = RunSweep(scenes, options, &progress);
    progress.Finish();
    EmitReport(report, json_path, markdown_path, plots_dir);
  });
}

}  // namespace linesight::cli
