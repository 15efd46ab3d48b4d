// The driver of `linesight eval report` (GenerateReport: input checks, studies in order, the page)
// and its provenance; the runs are in report_runs.cc, the sections in report_sections.cc.
#include "linesight/eval/report.h"

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "linesight/core/atomic_file.h"
#include "linesight/core/error.h"
#include "linesight/core/progress.h"
#include "linesight/eval/dataset.h"
#include "linesight/eval/eval_stereo.h"
#include "linesight/eval/report_internal.h"
#include "linesight/eval/result_cache.h"
#include "linesight/eval/sweep.h"
#include "linesight/stereo/matcher.h"

namespace linesight {
namespace fs = std::filesystem;

void ReportOptions::Check() const {
  CheckOption(!data_dir.empty(), "ReportOptions.data_dir", "(empty)", "name the data folder");
  CheckOption(!out_dir.empty(), "ReportOptions.out_dir", "(empty)", "name the output folder");
  CheckOption(!methods.empty(), "ReportOptions.methods", "(empty)", "name at least one method");
  CheckOption(!noise.empty() && noise.front().kind == NoiseSpec::Kind::kNone, "ReportOptions.noise",
              noise.empty() ? std::string("(empty)") : noise.front().Label(),
              "must start with clean");
  CheckOption(sweep_max_scenes >= 0, "ReportOptions.sweep_max_scenes", sweep_max_scenes,
              "must be >= 0");
  CheckOption(threads >= 0, "ReportOptions.threads", threads, "must be >= 0");
  CheckOption(gc_jobs >= 0, "ReportOptions.gc_jobs", gc_jobs, "must be >= 0 (0 = all cores)");
  CheckOption(!gc_cached_only || !cache_dir.empty(), "ReportOptions.gc_cached_only", "true",
              "needs a cache folder (--cache)");
  if (obstacles) obstacle_images.Check();
}

void ReportOptions::MakeQuick() {
  sets = {"middlebury-2001-2003"};
  noise_sets.clear();  // = every benchmark set
  sweep_sets.clear();  // = middlebury-2001-2003
  sweep_max_scenes = 2;
  obstacle_images.supersampling = 2;
}

std::string MachineDescription() {
  std::string model = "unknown CPU";
  std::ifstream cpuinfo("/proc/cpuinfo");
  std::string line;
  while (std::getline(cpuinfo, line)) {
    if (line.rfind("model name", 0) == 0) {
      const auto colon = line.find(':');
      if (colon != std::string::npos) {
        model = line.substr(colon + 1);
        model.erase(0, model.find_first_not_of(" \t"));
      }
      break;
    }
  }
  return fmt::format("{} ({} hardware threads)", model, std::thread::hardware_concurrency());
}

namespace {

// Output of a shell command (without the trailing newline); empty on failure.
std::string CommandOutput(const std::string& command) {
  std::FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return "";
  std::string out;
  char buffer[256];
  while (std::fgets(buffer, sizeof(buffer), pipe)) out += buffer;
  if (pclose(pipe) != 0) return "";
  while (!out.empty() && (out.back() == '\n' || out.back() == '\r')) out.pop_back();
  return out;
}

}  // namespace

std::string GitDescription(const fs::path& dir) {
  const std::string quoted = "'" + dir.string() + "'";
  if (dir.string().find('\'') != std::string::npos) return "unknown";
  const std::string commit =
      CommandOutput("git -C " + quoted + " describe --always --dirty --abbrev=12 2>/dev/null");
  if (commit.empty()) return "unknown";
  const std::string date =
      CommandOutput("TZ=UTC git -C " + quoted +
                    " log -1 --date=format-local:'%Y-%m-%d %H:%M UTC' --format=%cd 2>/dev/null");
  return date.empty() ? commit : fmt::format("{} ({})", commit, date);
}

std::string GenerateReport(const ReportOptions& options) {
  using detail::CacheSection;
  using detail::ComparisonSection;
  using detail::ConclusionSection;
  using detail::FilterScenes;
  using detail::GcJobs;
  using detail::InSets;
  using detail::MakeProgress;
  using detail::NoiseSection;
  using detail::Provenance;
  using detail::RunStudy;
  using detail::SceneKey;
  options.Check();
  // Every input check comes before the first file is written.
  for (const std::string& method : options.methods) CreateMatcher(method, MatcherOptions());
  for (const std::string& method : options.sweep_methods) CreateMatcher(method, MatcherOptions());
  const std::vector<SceneRef> all_scenes = FindScenes(options.data_dir);
  const std::vector<SceneRef> bench_scenes = SelectSets(all_scenes, options.sets, "--sets");
  if (bench_scenes.empty()) {
    throw InputError(fmt::format("{}: no benchmark scenes found", options.data_dir.string()));
  }
  SelectSets(bench_scenes, options.gc_sets, "--gc-sets");
  SelectSets(bench_scenes, options.gc_noise_sets, "--gc-noise-sets");
  const std::vector<SceneRef> noise_scenes =
      SelectSets(bench_scenes, options.noise_sets, "--noise-sets");
  std::vector<SceneRef> sweep_scenes;
  if (!options.sweep_sets.empty()) {
    sweep_scenes = SelectSets(all_scenes, options.sweep_sets, "--sweep-sets");
  } else {
    // Default: Middlebury 2001/2003 when present, else the first benchmark set.
    const bool classic =
        std::any_of(bench_scenes.begin(), bench_scenes.end(),
                    [](const SceneRef& s) { return s.set == "middlebury-2001-2003"; });
    const std::string set = classic ? "middlebury-2001-2003" : bench_scenes.front().set;
    sweep_scenes = SelectSets(bench_scenes, {set}, "--sweep-sets");
  }
  fs::create_directories(options.out_dir);
  std::optional<ResultCache> cache;
  if (!options.cache_dir.empty()) {
    cache.emplace(options.cache_dir, options.commit, MachineDescription());
  }
  std::vector<std::string> missing;  // gc cells without a cache entry (gc_cached_only)
  const Provenance prov{options.command_line, options.data_dir.string(), MachineDescription(),
                        options.commit, UtcNowText()};
  const bool run_gc =
      std::find(options.methods.begin(), options.methods.end(), "gc") != options.methods.end();
  const bool gc_everywhere =
      std::find(options.gc_sets.begin(), options.gc_sets.end(), "*") != options.gc_sets.end() ||
      SelectSets(bench_scenes, options.gc_sets, "--gc-sets").size() == bench_scenes.size();
  const bool gc_from_cache = !options.cache_dir.empty() &&
                             (InSets(options.cache_read_methods, "gc") || options.gc_cached_only);
  std::string gc_note =
      !run_gc
          ? "gc was not run."
          : fmt::format(
                "gc (graph cuts) ran on {}; each gc run is single-threaded and {} gc runs went "
                "side by side after the other methods, so its times are per run with one "
                "core.",
                gc_everywhere ? std::string("every set")
                              : fmt::format("the sets {} only", fmt::join(options.gc_sets, ", ")),
                GcJobs(options));
  if (run_gc && options.gc_cached_only) {
    gc_note =
        "gc (graph cuts) was not run by this page: every gc row comes from the result cache "
        "(--gc-cached-only) and carries the time of the single-threaded run that measured it; "
        "section 7 names its commit, machine and date, and lists the gc cells still missing.";
  } else if (run_gc && gc_from_cache) {
    gc_note +=
        " gc rows taken from the result cache carry the time of the run that measured them "
        "(section 7 names its commit, machine and date).";
  }

  // gc's noise runs: on the scenes of both gc_sets and gc_noise_sets.
  std::set<std::string> gc_noise_keys;
  for (const SceneRef& s :
       FilterScenes(FilterScenes(noise_scenes, options.gc_sets), options.gc_noise_sets)) {
    gc_noise_keys.insert(s.set + "/" + s.name);
  }
  const bool gc_noise_everywhere = gc_noise_keys.size() == noise_scenes.size();
  std::string gc_noise_note = gc_note;

  if (run_gc && !gc_noise_everywhere) {
    gc_noise_note += fmt::format(
        " In this noise study gc ran only on the sets {} (the gc row averages those scenes only, "
        "clean included): under strong noise a gc run takes 4-8 times its clean time.",
        fmt::join(options.gc_noise_sets, ", "));
  }

  // 2. Benchmarks (clean).
  const std::vector<EvalStereoResult> bench =
      RunStudy(bench_scenes, options.methods, {NoiseSpec()}, options.gc_sets, options,
               cache ? &*cache : nullptr, "benchmarks", &missing);
  // 3. Noise (clean results reused from the benchmark run).
  std::vector<NoiseSpec> noisy_specs(options.noise.begin() + 1, options.noise.end());
  std::vector<EvalStereoResult> noisy;
  std::set<std::string> noise_keys;
  for (const SceneRef& s : noise_scenes) noise_keys.insert(s.set + "/" + s.name);
  for (const EvalStereoResult& r : bench) {
    if (noise_keys.count(SceneKey(r)) && (r.method != "gc" || gc_noise_keys.count(SceneKey(r)))) {
      noisy.push_back(r);
    }
  }
  if (!noisy_specs.empty() && !noise_scenes.empty()) {
    std::vector<std::string> gc_noise_sets;
    for (const std::string& key : gc_noise_keys) {
      const std::string set = key.substr(0, key.find('/'));
      if (std::find(gc_noise_sets.begin(), gc_noise_sets.end(), set) == gc_noise_sets.end()) {
        gc_noise_sets.push_back(set);
      }
    }
    const auto extra = RunStudy(noise_scenes, options.methods, noisy_specs, gc_noise_sets, options,
                                cache ? &*cache : nullptr, "noise", &missing);
    noisy.insert(noisy.end(), extra.begin(), extra.end());
  }
  // 4. Parameter study.
  if (options.sweep_max_scenes > 0 &&
      sweep_scenes.size() > static_cast<size_t>(options.sweep_max_scenes)) {
    sweep_scenes.resize(options.sweep_max_scenes);
  }
  std::optional<SweepReport> sweep;
  if (!options.sweep_methods.empty()) {
    SweepOptions sweep_options;
    sweep_options.methods = options.sweep_methods;
    sweep_options.threads = options.threads;
    auto progress =
        MakeProgress(options, SweepSteps(sweep_options, sweep_scenes.size()), "parameter study");
    sweep = RunSweep(sweep_scenes, sweep_options, progress.get());
    progress->Finish();
  }
  // 5. Obstacles.
  std::optional<EvalObstaclesReport> obstacles;
  std::vector<StereoScene> obstacle_scenes;
  if (options.obstacles) {
    obstacle_scenes = RenderObstacleScenes(options.obstacle_images);
    EvalObstaclesOptions o;
    o.methods = options.methods;
    o.noise = options.noise;
    o.noise_seed = options.noise_seed;
    o.threads = options.threads;
    auto progress = MakeProgress(
        options, static_cast<int64_t>(obstacle_scenes.size() * o.methods.size() * o.noise.size()),
        "obstacle images");
    obstacles = RunEvalObstacles(obstacle_scenes, o, progress.get());
    progress->Finish();
  }

  // The page.
  std::string page = "# linesight — stereo matching comparison\n\n";
  page += fmt::format(
      "Generated by `{}` on {} from commit {}.\n\n- **Data**: `{}` — {} benchmark scene(s) in "
      "the sets {}.\n- **Machine**: {}. Times are wall-clock per Compute call with all cores "
      "(threads = {}) on a machine that may have been shared with other work; compare methods "
      "within this page only.\n- **Methods**: {}. {}\n\nSections: 1. comparison table · 2. "
      "benchmark tables · 3. noise robustness · 4. parameter study · 5. obstacle images · 6. "
      "conclusion{}.\n\n",
      prov.command, prov.date, prov.commit, prov.data, bench_scenes.size(),
      fmt::join(UniqueInOrder(bench, [](const auto& r) { return r.set; }), ", "), prov.machine,
      options.threads, fmt::join(options.methods, ", "), gc_note,
      cache ? " · 7. rows from the result cache" : "");
  std::set<std::string> cached_cells;  // clean rows are in both lists: count each cell once
  for (const std::vector<EvalStereoResult>* list :
       {&bench, static_cast<const std::vector<EvalStereoResult>*>(&noisy)}) {
    for (const EvalStereoResult& r : *list) {
      if (r.from_cache) cached_cells.insert(SceneKey(r) + "/" + r.noise + "/" + r.method);
    }
  }
  const size_t cached_rows = cached_cells.size();
  if (cache) {
    page += fmt::format(
        "**Result cache** `{}`: methods read from it: {}; {} benchmark/noise row(s) of this page "
        "come from it (measured by earlier runs: their commit, machine and date are listed in "
        "section 7), the rest were measured by this run.{}\n\n",
        options.cache_dir.string(), fmt::join(options.cache_read_methods, ", "), cached_rows,
        missing.empty() ? std::string()
                        : fmt::format(" **{} gc cell(s) are missing** (not in the cache, not run; "
                                      "listed in section 7).",
                                      missing.size()));
  }
  page += ComparisonSection(bench, options.methods, prov);

  page += "## 2. Stereo benchmarks (clean)\n\n" + gc_note + "\n\n";
  EvalStereoReport bench_report;
  bench_report.results = bench;
  page += bench_report.ToMarkdown();
  page += prov.Caption("Tables 2: benchmark metrics per set");

  std::vector<std::string> noise_labels;
  for (const NoiseSpec& n : options.noise) noise_labels.push_back(n.Label());
  page += NoiseSection(noisy, options.methods, options.noise, options.out_dir, prov, gc_noise_note);

  page += "## 4. Parameter study\n\n";
  if (sweep) {
    page += sweep->ToMarkdown();
    page += prov.Caption("Tables 4: parameter sweeps");
    for (const std::string& name : sweep->WritePlots(options.out_dir)) {
      page += fmt::format("![{}]({})\n\n", name, name);
    }
    page += prov.Caption(
        "Figures 2: sweep curves (sweep_rmse.svg: RMSE; sweep_bad.svg: headline bad %), one panel "
        "per parameter, one line per method");
  } else {
    page += "Not run (no sweep methods).\n\n";
  }

  page += "## 5. Obstacle images\n\n";
  if (obstacles) {
    std::vector<std::string> crops;
    for (const StereoScene& s : obstacle_scenes) {
      crops.push_back(fmt::format("{} ({}x{}, {} disparities)", s.ref.name, s.left.cols,
                                  s.left.rows, s.num_disparities));
    }
    page += fmt::format(
        "Synthetic power-line scene (sim::RenderPowerLineScene, seed {}, supersampling {}, ideal "
        "rectified pair, exact ground truth), one crop per obstacle: its bounding box grown by {} "
        "px is evaluated; the pair handed to the matchers extends that box to the left by the "
        "search range so every true match is inside it. Regions: obstacle pixels (mask) and every "
        "pixel of the box with ground truth (sky has none). Crops: {}. All methods (gc included) "
        "at every noise setting.\n\n",
        options.obstacle_images.seed, options.obstacle_images.supersampling,
        options.obstacle_images.margin_px, fmt::join(crops, ", "));
    page += obstacles->ToMarkdown();
    page += prov.Caption("Tables 5: obstacle crops");
    for (const std::string& name : obstacles->WritePlots(options.out_dir)) {
      page += fmt::format("![{}]({})\n\n", name, name);
      page += prov.Caption("Figure 3: bad-1 on obstacle pixels vs noise");
    }
  } else {
    page += "Not run.\n\n";
  }
  page += ConclusionSection(bench, noisy, noise_labels, options.methods, sweep ? &*sweep : nullptr,
                            obstacles ? &*obstacles : nullptr);
  if (cache) page += CacheSection(bench, noisy, missing);
  WriteTextAtomic(options.out_dir / "README.md", page);
  return page;
}

}  // namespace linesight