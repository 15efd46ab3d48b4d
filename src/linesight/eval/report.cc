#include "linesight/eval/report.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <exception>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <thread>
#include <tuple>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "linesight/core/atomic_file.h"
#include "linesight/core/error.h"
#include "linesight/core/progress.h"
#include "linesight/core/scoped_threads.h"
#include "linesight/eval/dataset.h"
#include "linesight/eval/eval_stereo.h"
#include "linesight/eval/plot.h"
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

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

bool InSets(const std::vector<std::string>& sets, const std::string& set) {
  return std::find(sets.begin(), sets.end(), "*") != sets.end() ||
         std::find(sets.begin(), sets.end(), set) != sets.end();
}

std::vector<SceneRef> FilterScenes(const std::vector<SceneRef>& scenes,
                                   const std::vector<std::string>& sets) {
  if (sets.empty()) return scenes;
  std::vector<SceneRef> out;
  for (const SceneRef& s : scenes) {
    if (InSets(sets, s.set)) out.push_back(s);
  }
  return out;
}

std::string SceneKey(const EvalStereoResult& r) { return r.set + "/" + r.scene; }

std::unique_ptr<ProgressBar> MakeProgress(const ReportOptions& options, int64_t total,
                                          const std::string& label) {
  return std::make_unique<ProgressBar>(total, label, options.show_progress && StderrIsTerminal());
}

int GcJobs(const ReportOptions& options) { return ResolveThreadCount(options.gc_jobs); }

// gc on every (scene, noise) pair, single-threaded runs side by side on GcJobs() threads. Every
// run is independent (own matcher, noise seeded per scene and view), so the results do not depend
// on the number of jobs; the first error is rethrown after all threads have stopped.
// Cache-only mode (options.gc_cached_only): cells without an entry go to `missing`.
std::vector<EvalStereoResult> RunGcJobs(const std::vector<SceneRef>& scenes,
                                        const std::vector<NoiseSpec>& noise,
                                        const ReportOptions& options, const ResultCache* cache,
                                        ProgressBar* progress, std::vector<std::string>* missing) {
  const size_t count = scenes.size() * noise.size();
  std::vector<EvalStereoReport> slots(count);
  std::vector<std::exception_ptr> errors(count);
  std::atomic<size_t> next{0};
  std::atomic<bool> failed{false};
  auto worker = [&] {
    for (size_t job = next++; job < count && !failed; job = next++) {
      try {
        EvalStereoOptions eval;
        eval.methods = {"gc"};
        eval.noise = {noise[job % noise.size()]};
        eval.noise_seed = options.noise_seed;
        eval.threads = 1;
        eval.cache = cache;
        eval.cache_read_methods = options.cache_read_methods;
        if (options.gc_cached_only) eval.cache_only_methods = {"gc"};
        slots[job] = RunEvalStereo({scenes[job / noise.size()]}, eval, progress);
      } catch (...) {
        errors[job] = std::current_exception();
        failed = true;
      }
    }
  };
  const int jobs = std::min<int>(GcJobs(options), static_cast<int>(count));
  std::vector<std::thread> threads;
  for (int i = 1; i < jobs; ++i) threads.emplace_back(worker);
  worker();
  for (std::thread& t : threads) t.join();
  for (const std::exception_ptr& e : errors) {
    if (e) std::rethrow_exception(e);
  }
  std::vector<EvalStereoResult> results;
  for (auto& slot : slots) {
    results.insert(results.end(), slot.results.begin(), slot.results.end());
    missing->insert(missing->end(), slot.missing.begin(), slot.missing.end());
  }
  return results;
}

// Runs `methods` on `scenes` at `noise`; gc only on the scenes of `gc_sets` and after the other
// methods (RunGcJobs). Results sorted by scene order, noise order, method order.
std::vector<EvalStereoResult> RunStudy(const std::vector<SceneRef>& scenes,
                                       const std::vector<std::string>& methods,
                                       const std::vector<NoiseSpec>& noise,
                                       const std::vector<std::string>& gc_sets,
                                       const ReportOptions& options, const ResultCache* cache,
                                       const std::string& label,
                                       std::vector<std::string>* missing) {
  std::vector<std::string> fast;
  bool gc = false;
  for (const std::string& m : methods) {
    if (m == "gc") {
      gc = true;
    } else {
      fast.push_back(m);
    }
  }
  const std::vector<SceneRef> gc_scenes =
      gc && !gc_sets.empty() ? FilterScenes(scenes, gc_sets) : std::vector<SceneRef>();
  const int64_t total = static_cast<int64_t>(noise.size()) *
                        static_cast<int64_t>(scenes.size() * fast.size() + gc_scenes.size());
  auto progress = MakeProgress(options, total, label);
  std::vector<EvalStereoResult> results;
  if (!fast.empty() && !scenes.empty()) {
    EvalStereoOptions eval;
    eval.noise = noise;
    eval.noise_seed = options.noise_seed;
    eval.threads = options.threads;
    eval.methods = fast;
    eval.cache = cache;
    eval.cache_read_methods = options.cache_read_methods;
    auto r = RunEvalStereo(scenes, eval, progress.get()).results;
    results.insert(results.end(), r.begin(), r.end());
  }
  if (!gc_scenes.empty()) {
    auto r = RunGcJobs(gc_scenes, noise, options, cache, progress.get(), missing);
    results.insert(results.end(), r.begin(), r.end());
  }
  progress->Finish();
  auto index = [](const auto& list, const std::string& key) {
    return std::find(list.begin(), list.end(), key) - list.begin();
  };
  std::vector<std::string> scene_order, noise_order;
  for (const SceneRef& s : scenes) scene_order.push_back(s.set + "/" + s.name);
  for (const NoiseSpec& n : noise) noise_order.push_back(n.Label());
  std::stable_sort(results.begin(), results.end(),
                   [&](const EvalStereoResult& a, const EvalStereoResult& b) {
                     return std::make_tuple(index(scene_order, SceneKey(a)),
                                            index(noise_order, a.noise), index(methods, a.method)) <
                            std::make_tuple(index(scene_order, SceneKey(b)),
                                            index(noise_order, b.noise), index(methods, b.method));
                   });
  return results;
}

// Mean headline figure (dense %) of `method` at `noise`, per set first and then over sets, over
// the scenes in `only` (null = all). NaN when nothing matched.
double MeanHeadline(const std::vector<EvalStereoResult>& results, const std::string& method,
                    const std::string& noise, const std::set<std::string>* only = nullptr,
                    const std::string& only_set = "") {
  std::map<std::string, std::pair<double, int>> per_set;
  for (const EvalStereoResult& r : results) {
    if (r.method != method || r.noise != noise) continue;
    if (only && !only->count(SceneKey(r))) continue;
    if (!only_set.empty() && r.set != only_set) continue;
    auto& [sum, n] = per_set[r.set];
    sum += PrimaryMetricFor(r).value;
    ++n;
  }
  if (per_set.empty()) return kNaN;
  double total = 0;
  for (const auto& [set, acc] : per_set) total += acc.first / acc.second;
  return total / static_cast<double>(per_set.size());
}

double TotalMs(const std::vector<EvalStereoResult>& results, const std::string& method,
               const std::string& noise, const std::set<std::string>* only = nullptr) {
  double total = 0;
  for (const EvalStereoResult& r : results) {
    if (r.method == method && r.noise == noise && (!only || only->count(SceneKey(r)))) {
      total += r.ms;
    }
  }
  return total;
}

std::set<std::string> ScenesOf(const std::vector<EvalStereoResult>& results,
                               const std::string& method, const std::string& noise) {
  std::set<std::string> out;
  for (const EvalStereoResult& r : results) {
    if (r.method == method && r.noise == noise) out.insert(SceneKey(r));
  }
  return out;
}

std::set<std::string> Intersect(const std::set<std::string>& a, const std::set<std::string>& b) {
  std::set<std::string> out;
  std::set_intersection(a.begin(), a.end(), b.begin(), b.end(), std::inserter(out, out.begin()));
  return out;
}

std::string Num(double v, int digits = 2) {
  return std::isnan(v) ? "–" : fmt::format("{:.{}f}", v, digits);
}

struct Provenance {
  std::string command, data, machine, commit, date;
  std::string Caption(const std::string& what) const {
    return fmt::format("*{} — produced by `{}` on data `{}`, machine: {}, commit {}, {}.*\n\n",
                       what, command, data, machine, commit, date);
  }
};

std::string ComparisonSection(const std::vector<EvalStereoResult>& bench,
                              const std::vector<std::string>& methods, const Provenance& prov) {
  std::string out = "## 1. Comparison table\n\n";
  const auto sets = UniqueInOrder(bench, [](const EvalStereoResult& r) { return r.set; });
  if (sets.empty()) return out + "No benchmark scene ran.\n\n";
  const std::string paper_set =
      std::find(sets.begin(), sets.end(), "middlebury-2001-2003") != sets.end()
          ? "middlebury-2001-2003"
          : sets.front();
  std::vector<std::string> scenes;
  std::string label;
  for (const EvalStereoResult& r : bench) {
    if (r.set != paper_set) continue;
    label = PrimaryMetricFor(r).label;
    if (std::find(scenes.begin(), scenes.end(), r.scene) == scenes.end()) {
      scenes.push_back(r.scene);
    }
  }
  out += fmt::format(
      "Correct-match rate = 100 − {} (dense: a pixel without an estimate is wrong) on `{}`, "
      "as in the papers' comparison tables; total operation time = sum of the wall times of one "
      "run per scene (load and scoring excluded, first-use allocations included). The last "
      "columns average the headline error over every set the method ran on (per set first).\n\n",
      label, paper_set);
  out += "| method |";
  std::string rule = "|---|";
  for (const std::string& s : scenes) {
    out += " " + s + " |";
    rule += "---|";
  }
  out += " mean correct % | total time (ms) | sets run | mean headline error over sets (%) |\n" +
         rule + "---|---|---|---|\n";
  for (const std::string& method : methods) {
    out += "| " + method + " |";
    double sum = 0, ms = 0;
    int n = 0;
    for (const std::string& s : scenes) {
      const auto it = std::find_if(bench.begin(), bench.end(), [&](const EvalStereoResult& r) {
        return r.set == paper_set && r.scene == s && r.method == method;
      });
      if (it == bench.end()) {
        out += " – |";
        continue;
      }
      const double correct = 100.0 - PrimaryMetricFor(*it).value;
      out += fmt::format(" {} |", Num(correct));
      sum += correct;
      ms += it->ms;
      ++n;
    }
    std::set<std::string> method_sets;
    for (const EvalStereoResult& r : bench) {
      if (r.method == method) method_sets.insert(r.set);
    }
    out += fmt::format(" {} | {} | {} | {} |\n", n ? Num(sum / n) : "–", n ? Num(ms, 0) : "–",
                       method_sets.size(), Num(MeanHeadline(bench, method, "clean")));
  }
  out += "\n" + prov.Caption("Table 1: correct-match rate and total operation time");
  return out;
}

std::string NoiseSection(const std::vector<EvalStereoResult>& noisy,
                         const std::vector<std::string>& methods,
                         const std::vector<NoiseSpec>& noise, const fs::path& out_dir,
                         const Provenance& prov, const std::string& gc_note) {
  std::string out = "## 3. Noise robustness\n\n";
  if (noisy.empty()) return out + "No scene ran.\n\n";
  std::vector<std::string> labels;
  for (const NoiseSpec& n : noise) labels.push_back(n.Label());
  const auto sets = UniqueInOrder(noisy, [](const EvalStereoResult& r) { return r.set; });
  out += fmt::format(
      "Noise added independently to both images (fixed seed; MATLAB imnoise definitions on [0,1] "
      "intensities: gauss = variance, sp = salt-and-pepper density). Headline error of each set "
      "(dense %), averaged per set and then over the sets each method ran on ({}). {}\n\n",
      fmt::join(sets, ", "), gc_note);
  // Scenes on which every method ran at every setting: the only fair ground for one summary row
  // per method when a method (gc) skipped some sets.
  std::set<std::string> common;
  bool first = true;
  for (const std::string& method : methods) {
    for (const std::string& l : labels) {
      const auto these = ScenesOf(noisy, method, l);
      common = first ? these : Intersect(common, these);
      first = false;
    }
  }
  const bool complete = common.size() == UniqueInOrder(noisy, SceneKey).size();
  auto table = [&](const std::string& only_set, const std::set<std::string>* only) {
    return MethodByNoiseTable(methods, labels,
                              [&](const std::string& method, const std::string& l) {
                                return MeanHeadline(noisy, method, l, only, only_set);
                              }) +
           "\n";
  };
  std::vector<std::string> common_sets;
  for (const std::string& key : common) {
    const std::string set = key.substr(0, key.find('/'));
    if (std::find(common_sets.begin(), common_sets.end(), set) == common_sets.end()) {
      common_sets.push_back(set);
    }
  }
  if (!complete && !common.empty()) {
    out +=
        fmt::format(
            "**Scenes every method ran at every setting** ({} scene(s) of {}; the same scenes for "
            "every row):\n\n",
            common.size(), fmt::join(common_sets, ", ")) +
        table("", &common);
  }
  out += std::string(complete ? "**All noise sets:**\n\n"
                              : "**All noise sets** (each method over the scenes it ran, so "
                                "rows with fewer sets are not comparable with the others):\n\n") +
         table("", nullptr);
  for (const std::string& set : sets) {
    std::string label;
    for (const auto& r : noisy) {
      if (r.set == set) label = PrimaryMetricFor(r).label;
    }
    out += fmt::format("**{}** ({}):\n\n", set, label) + table(set, nullptr);
    // A row that averages fewer scenes than the set has is not comparable with the others: say so.
    std::set<std::string> set_scenes;
    for (const auto& r : noisy) {
      if (r.set == set) set_scenes.insert(SceneKey(r));
    }
    std::vector<std::string> partial;
    for (const std::string& method : methods) {
      for (const std::string& l : labels) {
        size_t n = 0;
        for (const std::string& key : ScenesOf(noisy, method, l)) n += set_scenes.count(key);
        if (n > 0 && n < set_scenes.size()) {
          partial.push_back(
              fmt::format("{} at {}: {} of {} scenes", method, l, n, set_scenes.size()));
        }
      }
    }
    if (!partial.empty()) {
      out += fmt::format("Partial rows (mean over fewer scenes than the set has): {}.\n\n",
                         fmt::join(partial, "; "));
    }
  }
  // Every scene: every method on every scene at every setting, so no mean hides a scene.
  out += "<details><summary>Per scene (headline error of the scene's set, dense %)</summary>\n\n";
  out += "| set | scene | method |";
  for (const std::string& l : labels) out += " " + l + " |";
  out += "\n|---|---|---|";
  for (size_t i = 0; i < labels.size(); ++i) out += "---|";
  out += "\n";
  for (const std::string& key : UniqueInOrder(noisy, SceneKey)) {
    for (const std::string& method : methods) {
      std::string row;
      bool any = false;
      for (const std::string& l : labels) {
        const auto it = std::find_if(noisy.begin(), noisy.end(), [&](const EvalStereoResult& r) {
          return SceneKey(r) == key && r.method == method && r.noise == l;
        });
        any = any || it != noisy.end();
        row += fmt::format(" {} |", it == noisy.end() ? "–" : Num(PrimaryMetricFor(*it).value));
      }
      if (!any) continue;
      const auto slash = key.find('/');
      out += fmt::format("| {} | {} | {} |{}\n", key.substr(0, slash), key.substr(slash + 1),
                         method, row);
    }
  }
  out += "\n</details>\n\n";
  out += prov.Caption("Table 3: headline error vs noise");
  LineChart chart;
  chart.title = "Headline error vs image noise";
  chart.x_label = "noise (gauss: variance, sp: density)";
  chart.y_label = complete || common.empty() ? "headline bad % (mean over sets)"
                                             : "headline bad % (scenes every method ran)";
  chart.x_ticks = labels;
  for (const std::string& method : methods) {
    PlotSeries series{method, {}};
    for (const std::string& l : labels) {
      series.y.push_back(
          MeanHeadline(noisy, method, l, complete || common.empty() ? nullptr : &common));
    }
    chart.series.push_back(series);
  }
  WriteSvg(out_dir / "noise.svg", chart);
  out += "![headline error vs noise](noise.svg)\n\n" +
         prov.Caption(
             "Figure 1: headline error vs noise, one line per method (on the scenes every method "
             "ran when some method skipped a set)");
  return out;
}

std::string Verdict(double isgm, double other) {
  if (std::isnan(isgm) || std::isnan(other)) return "cannot be compared";
  if (std::abs(isgm - other) < 0.05) return "ties with";  // within 0.05 percentage points
  return isgm < other ? "beats" : "loses to";
}

std::string ConclusionSection(const std::vector<EvalStereoResult>& bench,
                              const std::vector<EvalStereoResult>& noisy,
                              const std::vector<std::string>& noise_labels,
                              const std::vector<std::string>& methods, const SweepReport* sweep,
                              const EvalObstaclesReport* obstacles) {
  std::string out =
      "## 6. Conclusion\n\nComputed from the numbers above (lower error is better; only scenes "
      "that both methods ran are compared).\n\n";
  const std::string ours = "isgm";
  const bool have_isgm =
      std::any_of(bench.begin(), bench.end(), [&](const auto& r) { return r.method == ours; });
  if (!have_isgm) {
    out += "isgm did not run, so there is nothing to compare it with.\n\n";
  } else {
    const auto ours_scenes = ScenesOf(bench, ours, "clean");
    for (const std::string& other : methods) {
      if (other == ours) continue;
      const auto common = Intersect(ours_scenes, ScenesOf(bench, other, "clean"));
      if (common.empty()) {
        out += fmt::format("- **isgm vs {}**: no common scene.\n", other);
        continue;
      }
      const double a = MeanHeadline(bench, ours, "clean", &common);
      const double b = MeanHeadline(bench, other, "clean", &common);
      std::vector<std::string> per_set;
      int better = 0, sets = 0;
      for (const std::string& set : UniqueInOrder(bench, [](const auto& r) { return r.set; })) {
        const double sa = MeanHeadline(bench, ours, "clean", &common, set);
        const double sb = MeanHeadline(bench, other, "clean", &common, set);
        if (std::isnan(sa) || std::isnan(sb)) continue;
        ++sets;
        if (sa < sb) ++better;
        per_set.push_back(fmt::format("{} {} vs {}", set, Num(sa), Num(sb)));
      }
      out += fmt::format(
          "- **isgm vs {}** — accuracy: isgm {} {} (mean headline error {} % vs {} % over {} "
          "scene(s); isgm better on {} of {} set(s): {}).",
          other, Verdict(a, b), other, Num(a), Num(b), common.size(), better, sets,
          fmt::join(per_set, "; "));
      // Noise.
      std::vector<std::string> noise_parts;
      int noise_better = 0, noise_n = 0;
      size_t noise_scene_count = 0;
      for (const std::string& l : noise_labels) {
        if (l == "clean") continue;
        const auto nc = Intersect(ScenesOf(noisy, ours, l), ScenesOf(noisy, other, l));
        if (nc.empty()) continue;
        const double na = MeanHeadline(noisy, ours, l, &nc);
        const double nb = MeanHeadline(noisy, other, l, &nc);
        ++noise_n;
        noise_scene_count = std::max(noise_scene_count, nc.size());
        if (na < nb) ++noise_better;
        noise_parts.push_back(fmt::format("{} {} vs {} ({})", l, Num(na), Num(nb),
                                          na < nb ? "better" : (na > nb ? "worse" : "equal")));
      }
      if (noise_n > 0) {
        out += fmt::format(
            " Noise (mean headline error over {} scene(s)): isgm is better at {} of {} noise "
            "setting(s): {}.",
            noise_scene_count, noise_better, noise_n, fmt::join(noise_parts, "; "));
      }
      // Time.
      const double ta = TotalMs(bench, ours, "clean", &common);
      const double tb = TotalMs(bench, other, "clean", &common);
      if (ta > 0 && tb > 0) {
        out += fmt::format(" Time: {:.0f} ms vs {:.0f} ms in total — isgm is {:.1f}× {}.", ta, tb,
                           ta < tb ? tb / ta : ta / tb, ta < tb ? "faster" : "slower");
      }
      // Obstacles.
      if (obstacles) {
        double oa = 0, ob = 0;
        int n = 0;
        for (const auto& ra : obstacles->results) {
          if (ra.method != ours || ra.noise != "clean") continue;
          for (const auto& rb : obstacles->results) {
            if (rb.method == other && rb.noise == "clean" && rb.scene == ra.scene) {
              oa += ra.regions.at("obstacle").bad[1];
              ob += rb.regions.at("obstacle").bad[1];
              ++n;
            }
          }
        }
        if (n > 0) {
          out += fmt::format(
              " Obstacle crops (clean): isgm {} {} (mean bad-1 on obstacle pixels {} % vs {} % "
              "over {} obstacle(s)).",
              Verdict(oa / n, ob / n), other, Num(oa / n), Num(ob / n), n);
        }
      }
      out += "\n";
    }
    // Real time.
    const auto ours_all = ScenesOf(bench, ours, "clean");
    double mde = 0, ms = 0;
    int n = 0;
    for (const auto& r : bench) {
      if (r.method == ours && r.noise == "clean") {
        mde += r.mde_s;
        ms += r.ms;
        ++n;
      }
    }
    if (n > 0) {
      out += fmt::format(
          "- **Speed of isgm**: {:.1f} ms per scene on average ({:.1f} frames/s, {:.0f} MDE/s) "
          "over {} scene(s) on this machine, shared with other work while the page was made.\n",
          ms / n, 1000.0 / (ms / n), mde / n, ours_all.size());
    }
  }
  // Best method overall (methods that ran on every set).
  const auto sets = UniqueInOrder(bench, [](const auto& r) { return r.set; });
  std::string best;
  double best_value = kNaN;
  for (const std::string& m : methods) {
    std::set<std::string> m_sets;
    for (const auto& r : bench) {
      if (r.method == m) m_sets.insert(r.set);
    }
    if (m_sets.size() != sets.size()) continue;
    const double v = MeanHeadline(bench, m, "clean");
    if (std::isnan(best_value) || v < best_value) {
      best_value = v;
      best = m;
    }
  }
  if (!best.empty()) {
    out += fmt::format(
        "- **Most accurate over every set** (among the methods that ran on all {} set(s)): {} "
        "(mean headline error {} %).\n",
        sets.size(), best, Num(best_value));
  }
  if (sweep) {
    for (const SweepCurve& c : sweep->curves) {
      if (c.points.empty()) continue;
      const auto best_point =
          std::min_element(c.points.begin(), c.points.end(),
                           [](const SweepPoint& x, const SweepPoint& y) { return x.bad < y.bad; });
      const auto centre = std::find_if(c.points.begin(), c.points.end(),
                                       [&](const SweepPoint& p) { return p.value == c.centre; });
      out += fmt::format("- Parameter study, {} {}: lowest {} at {} ({} %; centre {}: {} %).\n",
                         c.method, c.key, sweep->bad_label, best_point->value, Num(best_point->bad),
                         c.centre, centre == c.points.end() ? "–" : Num(centre->bad));
    }
  }
  return out + "\n";
}

// Section 7: every row taken from the result cache, with the run that measured it, and the cells
// that are missing.
std::string CacheSection(const std::vector<EvalStereoResult>& bench,
                         const std::vector<EvalStereoResult>& noisy,
                         const std::vector<std::string>& missing) {
  std::string out = "## 7. Rows from the result cache\n\n";
  std::string rows;
  std::set<std::string> seen;
  int n = 0;
  double ms = 0;
  for (const std::vector<EvalStereoResult>* list :
       {&bench, static_cast<const std::vector<EvalStereoResult>*>(&noisy)}) {
    for (const EvalStereoResult& r : *list) {
      if (!r.from_cache) continue;
      const std::string cell = SceneKey(r) + "/" + r.noise + "/" + r.method;
      if (!seen.insert(cell).second) continue;  // clean rows appear in both lists
      rows += fmt::format("| {} | {} | {} | {} | {:.1f} | {} | {} | {} |\n", r.set, r.scene,
                          r.noise, r.method, r.ms / 1000.0, r.measured_commit, r.measured_date,
                          r.measured_machine);
      ++n;
      ms += r.ms;
    }
  }
  if (n == 0) {
    out += "No row of this page came from the cache.\n\n";
  } else {
    out += fmt::format(
               "{} row(s), {:.0f} s of measured compute in total. Their metrics and times are "
               "those of the run named here (times of cached gc rows: one single-threaded run, "
               "niced, on a machine shared with other work).\n\n",
               n, ms / 1000.0) +
           "| set | scene | noise | method | s | measured by commit | date | machine |\n"
           "|---|---|---|---|---|---|---|---|\n" +
           rows + "\n";
  }
  if (missing.empty()) {
    out += "No cell is missing.\n\n";
  } else {
    out += fmt::format(
        "**Missing** ({} cell(s): gc was read from the cache only and these have no entry yet; "
        "fill them with `linesight eval stereo --methods gc --threads 1 --cache DIR --sets SET "
        "--noise clean,gauss:0.1,gauss:0.2,sp:0.15,sp:0.35`):\n\n",
        missing.size());
    // One line per scene and method: "set/scene (method): noise, noise".
    std::vector<std::pair<std::string, std::vector<std::string>>> by_scene;
    for (const std::string& m : missing) {
      // m = set/scene/noise/method; noise labels hold no '/'.
      const auto method_at = m.rfind('/');
      const auto noise_at = m.rfind('/', method_at - 1);
      const std::string scene =
          fmt::format("{} ({})", m.substr(0, noise_at), m.substr(method_at + 1));
      const std::string noise = m.substr(noise_at + 1, method_at - noise_at - 1);
      auto it = std::find_if(by_scene.begin(), by_scene.end(),
                             [&](const auto& entry) { return entry.first == scene; });
      if (it == by_scene.end()) {
        by_scene.push_back({scene, {}});
        it = by_scene.end() - 1;
      }
      it->second.push_back(noise);
    }
    for (const auto& [scene, noises] : by_scene) {
      out += fmt::format("- `{}`: {}\n", scene, fmt::join(noises, ", "));
    }
    out += "\n";
  }
  return out;
}

}  // namespace

std::string GenerateReport(const ReportOptions& options) {
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
