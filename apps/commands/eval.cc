// linesight eval <study>: `stereo` (benchmarks), `calibration` and `ranging` (simulation studies).
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <optional>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "cli.h"
#include "commands.h"
#include "linesight/core/error.h"
#include "linesight/core/progress.h"
#include "linesight/eval/eval_stereo.h"
#include "linesight/eval/report.h"
#include "linesight/eval/result_cache.h"
#include "linesight/stereo/matcher.h"

namespace linesight::cli {
namespace {

std::vector<std::string> SplitComma(const std::string& text) {
  std::vector<std::string> out;
  size_t start = 0;
  while (start <= text.size()) {
    const size_t comma = text.find(',', start);
    const std::string item = text.substr(start, comma == std::string::npos ? comma : comma - start);
    if (!item.empty()) out.push_back(item);
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return out;
}

int RunEvalStereo(int argc, char** argv) {
  CLI::App app{
      "Run matchers on public stereo benchmarks (layouts found under --data) and score them "
      "with the benchmarks' own metrics.",
      "eval stereo"};
  std::string data_dir, methods_text = "sgbm,bm", json_path, plots_dir, save_dir, markdown_path;
  std::vector<std::string> raw_params;
  std::vector<std::string> only_sets;
  std::vector<std::string> noise_texts = {"clean"};
  uint64_t noise_seed = 1;
  int threads = 0;
  app.add_option("--data", data_dir, "folder holding benchmark scenes (searched recursively)")
      ->required();
  app.add_option("--methods", methods_text,
                 fmt::format("comma-separated methods: {}", fmt::join(MatcherNames(), ", ")))
      ->capture_default_str();
  app.add_option("--sets", only_sets, "only these sets (folder names), comma-separated")
      ->delimiter(',');
  AddParamOption(app, &raw_params);
  app.add_option("--noise", noise_texts,
                 "noise settings, comma-separated: clean, gauss:VARIANCE, sp:DENSITY (on [0,1] "
                 "intensities, e.g. clean,gauss:0.1,gauss:0.2,sp:0.15,sp:0.35)")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--noise-seed", noise_seed, "seed of the image noise")->capture_default_str();
  app.add_option("--threads", threads, "matcher threads (0 = all cores)")->capture_default_str();
  app.add_option("--json", json_path, "JSON report (- for stdout)");
  app.add_option("--markdown", markdown_path, "also write the markdown tables to this file");
  app.add_option("--plots", plots_dir, "write colour disparity and error maps here");
  app.add_option("--save-disparity", save_dir,
                 "write every disparity map as <dir>/<set>/<scene>/<method>.pfm");
  std::string cache_dir;
  std::vector<std::string> cache_read = {"*"};
  app.add_option("--cache", cache_dir,
                 "result cache folder: cells found there with exactly the same key (settings, "
                 "noise, input and ground-truth fingerprints, algorithm version) are not run "
                 "again; every computed cell is stored");
  app.add_option("--cache-read", cache_read,
                 "methods whose results are read from the cache (* = all; others only write)")
      ->delimiter(',')
      ->capture_default_str();
  return RunCommand(app, argc, argv, [&] {
    EvalStereoOptions options;
    options.methods = SplitComma(methods_text);
    options.params = ParseParams(raw_params);
    options.threads = threads;
    options.noise.clear();
    for (const std::string& text : noise_texts) options.noise.push_back(NoiseSpec::Parse(text));
    options.noise_seed = noise_seed;
    options.save_disparity_dir = save_dir;
    options.plots_dir = plots_dir;
    std::optional<ResultCache> cache;
    if (!cache_dir.empty()) {
      std::error_code error;
      const auto exe = std::filesystem::read_symlink("/proc/self/exe", error);
      cache.emplace(cache_dir,
                    GitDescription(error ? std::filesystem::current_path() : exe.parent_path()),
                    MachineDescription());
      options.cache = &*cache;
      options.cache_read_methods = cache_read;
    }
    const std::vector<SceneRef> scenes = SelectSets(FindScenes(data_dir), only_sets, "--sets");
    if (scenes.empty()) {
      throw InputError(
          fmt::format("{}: no benchmark scenes found (expected Middlebury, KITTI, ETH3D, "
                      "Scene Flow or opencv-doc Aloe layouts)",
                      data_dir));
    }
    ProgressBar progress(
        static_cast<int64_t>(scenes.size() * options.methods.size() * options.noise.size()),
        "eval stereo");
    const EvalStereoReport report = RunEvalStereo(scenes, options, &progress);
    progress.Finish();
    EmitReport(report, json_path, markdown_path, plots_dir);
  });
}

struct Study {
  const char* name;
  int (*run)(int, char**);
  const char* summary;
};

constexpr Study kStudies[] = {
    {"stereo", RunEvalStereo, "matchers on public benchmarks (Middlebury, KITTI, ETH3D, ...)"},
    {"calibration", RunEvalCalibration,
     "calibration simulation study: zhang / recon / opencv vs the Cramer-Rao bound"},
    {"ranging", RunEvalRanging,
     "ranging accuracy on rendered power-line scenes + Middlebury metric depth"},
    {"sweep", RunEvalSweep, "parameter study: one parameter at a time (SGBM family, isgm)"},
    {"obstacles", RunEvalObstacles, "matchers on rendered damper / clamp / insulator crops"},
    {"plates", RunEvalPlates,
     "ranging on an independent renderer's plates / boxes (photograph textures)"},
    {"sequences", RunEvalSequences,
     "obstacle awareness on moving power-line sequences (detection, type, distance, tracks)"},
    {"faults", RunEvalFaults,
     "conductor faults on sequences with seeded defects (recall by type, distance, size)"},
    {"report", RunEvalReport, "run every study and write docs/results/README.md"},
};

void PrintEvalUsage(std::FILE* out) {
  std::fprintf(
      out,
      "usage: linesight eval <study> [options]   (linesight eval <study> --help)\n\nstudies:\n");
  for (const Study& s : kStudies) std::fprintf(out, "  %-12s %s\n", s.name, s.summary);
}

}  // namespace

int RunEval(int argc, char** argv) {
  if (argc < 2) {
    PrintEvalUsage(stderr);
    return kExitUsage;
  }
  if (!std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h")) {
    PrintEvalUsage(stdout);
    return kExitOk;
  }
  for (const Study& s : kStudies) {
    if (!std::strcmp(argv[1], s.name)) return s.run(argc - 1, argv + 1);
  }
  std::fprintf(stderr, "eval: unknown study '%s' (see linesight eval --help)\n", argv[1]);
  return kExitUsage;
}

}  // namespace linesight::cli
