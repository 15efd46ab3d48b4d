// The sections of the `linesight eval report` page (report_internal.h): markdown tables, plots and
// the conclusion, computed from the study results.
#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>
#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "linesight/eval/plot.h"
#include "linesight/eval/report_internal.h"

namespace linesight::detail {
namespace fs = std::filesystem;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

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

}  // namespace

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
  // Every scene: each method on each scene at each setting.
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

namespace {

std::string Verdict(double isgm, double other) {
  if (std::isnan(isgm) || std::isnan(other)) return "cannot be compared";
  if (std::abs(isgm - other) < 0.05) return "ties with";  // within 0.05 percentage points
  return isgm < other ? "beats" : "loses to";
}

}  // namespace

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

}  // namespace linesight::detail
