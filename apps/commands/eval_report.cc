// linesight eval report: regenerates the results page (src/linesight/eval/report.h).
#include <filesystem>
#include <iostream>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "cli.h"
#include "commands.h"
#include "linesight/core/error.h"
#include "linesight/eval/report.h"

namespace linesight::cli {

int RunEvalReport(int argc, char** argv) {
  CLI::App app{
      "Run the whole comparison study (benchmarks, noise, parameter sweeps, obstacle images) and "
      "write one markdown page with every table and plot plus a conclusion computed from the "
      "numbers.",
      "eval report"};
  ReportOptions options;
  std::string data_dir, out_dir = "docs/results";
  std::vector<std::string> noise_texts;
  for (const NoiseSpec& n : options.noise) noise_texts.push_back(n.Label());
  bool quick = false, no_obstacles = false, no_gc = false;
  app.add_option("--data", data_dir, "folder holding benchmark scenes (searched recursively)")
      ->required();
  app.add_option("--out", out_dir, "output folder for README.md and the SVG plots")
      ->capture_default_str();
  app.add_flag("--quick", quick,
               "smaller run: middlebury-2001-2003 only, sweep on 2 scenes, obstacle images with "
               "supersampling 2");
  app.add_option("--methods", options.methods, "methods, comma-separated (isgm is compared)")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--sets", options.sets, "benchmark sets (default: every set found)")
      ->delimiter(',');
  app.add_option("--gc-sets", options.gc_sets,
                 "sets gc (seconds to minutes per scene) runs on; * = every set")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option(
         "--gc-noise-sets", options.gc_noise_sets,
         "sets on which gc also runs the noise settings (4-8x its clean time); * = every set")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--gc-jobs", options.gc_jobs,
                 "gc runs side by side, each single-threaded (0 = one per hardware thread)")
      ->capture_default_str();
  app.add_flag("--no-gc", no_gc, "leave gc out entirely");
  app.add_option("--noise", noise_texts, "noise settings, clean first")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--noise-sets", options.noise_sets,
                 "sets of the noise study (default: every benchmark set)")
      ->delimiter(',');
  app.add_option("--sweep-methods", options.sweep_methods, "methods of the parameter study")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--sweep-sets", options.sweep_sets,
                 "sets of the parameter study (default: middlebury-2001-2003 when present)")
      ->delimiter(',');
  app.add_flag("--no-obstacles", no_obstacles, "skip the rendered obstacle images");
  app.add_option("--threads", options.threads, "matcher threads (0 = all cores)")
      ->capture_default_str();
  std::string cache_dir;
  app.add_option("--cache", cache_dir,
                 "result cache folder (e.g. /work/cache/eval): every result is stored there and "
                 "the --cache-read methods are taken from it on an exact key match");
  app.add_option("--cache-read", options.cache_read_methods,
                 "methods whose results are read from the cache (* = all)")
      ->delimiter(',')
      ->capture_default_str();
  app.add_flag("--gc-cached-only", options.gc_cached_only,
               "do not run gc: take its cells from --cache and list the missing ones on the page");
  std::string command_line = "linesight eval";  // argv[0] is the study name ("report")
  for (int i = 0; i < argc; ++i) command_line += fmt::format(" {}", argv[i]);
  return RunCommand(app, argc, argv, [&] {
    options.data_dir = data_dir;
    options.cache_dir = cache_dir;
    options.out_dir = out_dir;
    options.noise.clear();
    for (const std::string& text : noise_texts) options.noise.push_back(NoiseSpec::Parse(text));
    const bool sets_given = !options.sets.empty();
    if (quick) {
      const auto explicit_sets = options.sets;
      options.MakeQuick();
      if (sets_given) options.sets = explicit_sets;
    }
    if (no_gc) std::erase(options.methods, std::string("gc"));
    options.obstacles = !no_obstacles;
    options.command_line = command_line;
    // The sources the binary was built from: the work tree holding the executable (build folders
    // live inside it), else the current directory.
    std::error_code error;
    const auto exe = std::filesystem::read_symlink("/proc/self/exe", error);
    options.commit = GitDescription(error ? std::filesystem::current_path() : exe.parent_path());
    GenerateReport(options);
    std::cerr << fmt::format("eval report: wrote {}\n",
                             (std::filesystem::path(out_dir) / "README.md").string());
  });
}

}  // namespace linesight::cli
