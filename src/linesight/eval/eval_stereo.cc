#include "linesight/eval/eval_stereo.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <opencv2/imgproc.hpp>

#include "linesight/core/error.h"
#include "linesight/core/progress.h"
#include "linesight/core/timer.h"
#include "linesight/eval/plot.h"
#include "linesight/eval/result_cache.h"
#include "linesight/io/disparity_io.h"
#include "linesight/io/image_io.h"
#include "linesight/io/pfm.h"
#include "linesight/stereo/matcher.h"

namespace linesight {
namespace fs = std::filesystem;

void EvalStereoOptions::Check() const {
  CheckOption(!methods.empty(), "EvalStereoOptions.methods", "(empty)", "name at least one method");
  CheckOption(threads >= 0, "EvalStereoOptions.threads", threads, "must be >= 0");
  CheckOption(cache != nullptr || cache_only_methods.empty(),
              "EvalStereoOptions.cache_only_methods",
              fmt::format("{}", fmt::join(cache_only_methods, ",")), "needs a cache");
}

namespace {

void SaveOutputs(const EvalStereoOptions& options, const StereoScene& scene,
                 const std::string& noise, const std::string& method, const cv::Mat& disparity) {
  fs::path rel = fs::path(scene.ref.set) / scene.ref.name;
  if (noise != "clean") rel /= noise;
  if (!options.save_disparity_dir.empty()) {
    const fs::path dir = options.save_disparity_dir / rel;
    fs::create_directories(dir);
    WritePfm(dir / (method + ".pfm"), disparity);
  }
  if (!options.plots_dir.empty()) {
    const fs::path dir = options.plots_dir / rel;
    fs::create_directories(dir);
    const float lo = static_cast<float>(scene.min_disparity);
    const float hi = static_cast<float>(scene.min_disparity + scene.num_disparities - 1);
    WriteImage(dir / (method + "_disparity.png"), ColorizeDisparityWithLegend(disparity, lo, hi));
    WriteImage(dir / (method + "_error.png"),
               ColorizeDisparityError(disparity, scene.ground_truth));
    const fs::path gt = dir / "ground_truth.png";
    if (!fs::exists(gt)) WriteImage(gt, ColorizeDisparityWithLegend(scene.ground_truth, lo, hi));
  }
}

std::string Fmt2(double v) { return fmt::format("{:.2f}", v); }

bool Contains(const std::vector<std::string>& list, const std::string& item) {
  return std::find(list.begin(), list.end(), item) != list.end();
}

}  // namespace

std::map<std::string, std::string> ParamsForMethod(const std::map<std::string, std::string>& params,
                                                   const std::string& method) {
  std::map<std::string, std::string> out;
  for (const auto& [key, value] : params) {
    const auto dot = key.find('.');
    if (dot == std::string::npos) {
      out[key] = value;
    } else if (key.substr(0, dot) == method) {
      out[key.substr(dot + 1)] = value;
    }
  }
  return out;
}

uint64_t NoiseSeedFor(const std::string& key, uint64_t seed) {
  uint64_t h = 1469598103934665603ull ^ seed;
  for (unsigned char c : key) h = (h ^ c) * 1099511628211ull;
  return h;
}

void CheckStudyMethods(const std::vector<std::string>& methods,
                       const std::map<std::string, std::string>& params) {
  for (const std::string& method : methods) {
    MatcherOptions probe;
    probe.params = ParamsForMethod(params, method);
    CreateMatcher(method, probe);
  }
}

MatcherOptions StudyMatcherOptions(const std::string& method, int min_disparity,
                                   int num_disparities, int threads,
                                   const std::map<std::string, std::string>& params) {
  MatcherOptions m;
  m.min_disparity = min_disparity;
  m.num_disparities = num_disparities;
  m.threads = threads;
  m.params = ParamsForMethod(params, method);
  return m;
}

NoisyPair AddPairNoise(const cv::Mat& left, const cv::Mat& right, const NoiseSpec& noise,
                       const std::string& key, uint64_t seed) {
  return {AddImageNoise(left, noise, NoiseSeedFor(key + "/left", seed)),
          AddImageNoise(right, noise, NoiseSeedFor(key + "/right", seed))};
}

std::vector<SceneRef> SelectSets(const std::vector<SceneRef>& scenes,
                                 const std::vector<std::string>& sets, const std::string& what) {
  const bool all = sets.empty() || std::find(sets.begin(), sets.end(), "*") != sets.end();
  std::vector<std::string> available;
  for (const SceneRef& s : scenes) {
    if (std::find(available.begin(), available.end(), s.set) == available.end()) {
      available.push_back(s.set);
    }
  }
  if (!all) {
    for (const std::string& set : sets) {
      if (std::find(available.begin(), available.end(), set) == available.end()) {
        throw InputError(fmt::format("{}: unknown set '{}' (sets found: {})", what, set,
                                     available.empty()
                                         ? std::string("none")
                                         : fmt::format("{}", fmt::join(available, ", "))));
      }
    }
  }
  std::vector<SceneRef> out;
  for (const SceneRef& s : scenes) {
    if (all || std::find(sets.begin(), sets.end(), s.set) != sets.end()) out.push_back(s);
  }
  return out;
}

PrimaryMetric PrimaryMetricFor(const EvalStereoResult& r) {
  const bool has_nonocc = r.regions.count("nonocc") > 0;
  const std::string region = has_nonocc ? "nonocc" : "all";
  auto find = [&](const std::string& reg) -> const DisparityMetrics& { return r.regions.at(reg); };
  if (r.set.find("kitti") != std::string::npos) {
    return {"D1 all", "all", find("all").d1};
  }
  if (r.set.find("2005") != std::string::npos || r.set.find("2006") != std::string::npos ||
      r.set.find("2014") != std::string::npos) {
    return {"bad-2.0 " + region, region, find(region).bad[2]};
  }
  return {"bad-1.0 " + region, region, find(region).bad[1]};
}

EvalStereoReport RunEvalStereo(const std::vector<SceneRef>& scenes,
                               const EvalStereoOptions& options, ProgressBar* progress) {
  options.Check();
  CheckStudyMethods(options.methods, options.params);
  EvalStereoReport report;
  for (const SceneRef& ref : scenes) {
    const StereoScene scene = LoadScene(ref);
    for (const NoiseSpec& noise : options.noise) {
      const std::string noise_label = noise.Label();
      const std::string scene_key = ref.set + "/" + ref.name + "/" + noise_label;
      const auto [left, right] =
          AddPairNoise(scene.left, scene.right, noise, scene_key, options.noise_seed);
      for (const std::string& method : options.methods) {
        const MatcherOptions matcher_options = StudyMatcherOptions(
            method, scene.min_disparity, scene.num_disparities, options.threads, options.params);
        auto matcher = CreateMatcher(method, matcher_options);
        const std::string cell = fmt::format("{}/{} {} {}", ref.set, ref.name, noise_label, method);
        nlohmann::json key;
        if (options.cache) {
          key = MakeResultCacheKey(scene, method, matcher->Settings(), noise, options.noise_seed,
                                   left, right);
          const bool read = Contains(options.cache_read_methods, "*") ||
                            Contains(options.cache_read_methods, method) ||
                            Contains(options.cache_only_methods, method);
          if (read) {
            if (auto cached = options.cache->Find(key)) {
              report.results.push_back(std::move(*cached));
              if (progress) progress->Advance(1, cell + " (cached)");
              continue;
            }
          }
        }
        if (Contains(options.cache_only_methods, method)) {
          report.missing.push_back(
              fmt::format("{}/{}/{}/{}", ref.set, ref.name, noise_label, method));
          if (progress) progress->Advance(1, cell + " (not cached, skipped)");
          continue;
        }
        Stopwatch watch;
        const cv::Mat disparity = matcher->Compute(left, right).disparity;
        const double ms = watch.ElapsedMs();

        EvalStereoResult result;
        result.set = ref.set;
        result.scene = ref.name;
        result.method = method;
        result.noise = noise_label;
        result.width = scene.left.cols;
        result.height = scene.left.rows;
        result.min_disparity = scene.min_disparity;
        result.num_disparities = scene.num_disparities;
        result.ms = ms;
        result.mde_s = MdePerSecond(result.width, result.height, result.num_disparities, ms);
        result.settings = matcher->Settings();
        for (const auto& [region, mask] : scene.masks) {
          result.regions[region] = ComputeDisparityMetrics(disparity, scene.ground_truth, mask);
        }
        SaveOutputs(options, scene, noise_label, method, disparity);
        if (options.cache) options.cache->Store(key, result);
        report.results.push_back(std::move(result));
        if (progress) progress->Advance(1, cell);
      }
    }
  }
  return report;
}

nlohmann::json EvalStereoReport::ToJson() const {
  nlohmann::json scenes = nlohmann::json::array();
  for (const EvalStereoResult& r : results) {
    const PrimaryMetric primary = PrimaryMetricFor(r);
    nlohmann::json measured = nullptr;
    if (r.from_cache) {
      measured = {{"commit", r.measured_commit},
                  {"machine", r.measured_machine},
                  {"date", r.measured_date}};
    }
    nlohmann::json row = EvalStereoResultToJson(r);
    row["primary"] = {{"label", primary.label}, {"value", primary.value}};
    row["from_cache"] = r.from_cache;
    row["cache_measured"] = measured;
    scenes.push_back(std::move(row));
  }
  return {{"scenes", scenes}, {"missing_from_cache", missing}};
}

namespace {

// Mean headline figure of `method` at `noise` over all scenes (averaged per set first, then over
// sets, so a set with many scenes does not dominate). NaN when nothing matched.
double MeanPrimary(const std::vector<EvalStereoResult>& results, const std::string& method,
                   const std::string& noise) {
  std::map<std::string, std::pair<double, int>> per_set;
  for (const auto& r : results) {
    if (r.method != method || r.noise != noise) continue;
    auto& [sum, n] = per_set[r.set];
    sum += PrimaryMetricFor(r).value;
    ++n;
  }
  if (per_set.empty()) return std::numeric_limits<double>::quiet_NaN();
  double total = 0;
  for (const auto& [set, acc] : per_set) total += acc.first / acc.second;
  return total / static_cast<double>(per_set.size());
}

}  // namespace

std::string EvalStereoReport::ToMarkdown() const {
  std::string out;
  const auto sets = UniqueInOrder(results, [](const EvalStereoResult& r) { return r.set; });
  const auto noises = UniqueInOrder(results, [](const EvalStereoResult& r) { return r.noise; });
  const auto methods = UniqueInOrder(results, [](const EvalStereoResult& r) { return r.method; });
  for (const std::string& set : sets) {
    for (const std::string& noise : noises) {
      std::vector<const EvalStereoResult*> rows;
      for (const auto& r : results) {
        if (r.set == set && r.noise == noise) rows.push_back(&r);
      }
      if (rows.empty()) continue;
      const PrimaryMetric primary = PrimaryMetricFor(*rows.front());
      out += fmt::format(
          "### {}{}\n\nDense metrics (a pixel without an estimate is an error) on region "
          "`{}`; headline: {}.\n\n",
          set, noise == "clean" ? "" : " — noise " + noise, primary.region, primary.label);
      out +=
          "| scene | method | bad-0.5 | bad-1 | bad-2 | bad-4 | D1 | avgerr | rmse | density | ms "
          "| "
          "MDE/s |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n";
      for (const EvalStereoResult* r : rows) {
        const DisparityMetrics& m = r->regions.at(primary.region);
        out += fmt::format(
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {:.1f} | {:.0f} |\n", r->scene,
            r->method, Fmt2(m.bad[0]), Fmt2(m.bad[1]), Fmt2(m.bad[2]), Fmt2(m.bad[3]), Fmt2(m.d1),
            Fmt2(m.avgerr), Fmt2(m.rmse), Fmt2(m.density), r->ms, r->mde_s);
      }
      out += fmt::format(
          "\nAverage over the set:\n\n| method | {} | density | ms |\n|---|---|---|---|\n",
          primary.label);
      for (const std::string& method : methods) {
        double sum = 0, density = 0, ms = 0;
        int n = 0;
        for (const EvalStereoResult* r : rows) {
          if (r->method != method) continue;
          sum += PrimaryMetricFor(*r).value;
          density += r->regions.at(primary.region).density;
          ms += r->ms;
          ++n;
        }
        if (n == 0) continue;
        out += fmt::format("| {} | {:.2f} | {:.2f} | {:.1f} |\n", method, sum / n, density / n,
                           ms / n);
      }
      out += "\n";
    }
  }
  if (noises.size() > 1) {
    out +=
        "### Noise robustness\n\nHeadline error of each set (dense, %), averaged per set and then "
        "over "
        "sets:\n\n";
    out += MethodByNoiseTable(methods, noises,
                              [&](const std::string& method, const std::string& noise) {
                                return MeanPrimary(results, method, noise);
                              });
    out += "\n";
  }
  std::string cached;
  for (const auto& r : results) {
    if (!r.from_cache) continue;
    cached += fmt::format("| {} | {} | {} | {} | {} | {} | {} |\n", r.set, r.scene, r.noise,
                          r.method, r.measured_commit, r.measured_date, r.measured_machine);
  }
  if (!cached.empty()) {
    out +=
        "Rows taken from the result cache (their metrics and ms were measured by an earlier "
        "run):\n\n| set | scene | noise | method | commit | date | machine |\n"
        "|---|---|---|---|---|---|---|\n" +
        cached + "\n";
  }
  if (!missing.empty()) {
    out += fmt::format("Not run (cache-only methods without a cache entry): {}.\n\n",
                       fmt::join(missing, ", "));
  }
  return out;
}

std::string MethodByNoiseTable(
    const std::vector<std::string>& methods, const std::vector<std::string>& noises,
    const std::function<double(const std::string&, const std::string&)>& value) {
  std::string out = "| method |";
  for (const std::string& noise : noises) out += " " + noise + " |";
  out += "\n|---|";
  for (size_t i = 0; i < noises.size(); ++i) out += "---|";
  out += "\n";
  for (const std::string& method : methods) {
    out += "| " + method + " |";
    for (const std::string& noise : noises) {
      const double v = value(method, noise);
      out += std::isnan(v) ? std::string(" – |") : fmt::format(" {:.2f} |", v);
    }
    out += "\n";
  }
  return out;
}

bool WriteNoiseChart(
    const std::vector<EvalStereoResult>& results, const std::string& title,
    const std::string& y_label,
    const std::function<double(const std::string& method, const std::string& noise)>& value,
    const fs::path& file) {
  const auto noises = UniqueInOrder(results, [](const EvalStereoResult& r) { return r.noise; });
  const auto methods = UniqueInOrder(results, [](const EvalStereoResult& r) { return r.method; });
  if (noises.size() < 2) return false;
  LineChart chart;
  chart.title = title;
  chart.x_label = "noise (gauss: variance, sp: density)";
  chart.y_label = y_label;
  chart.x_ticks = noises;
  for (const std::string& method : methods) {
    PlotSeries series{method, {}};
    for (const std::string& noise : noises) series.y.push_back(value(method, noise));
    chart.series.push_back(series);
  }
  fs::create_directories(file.parent_path());
  WriteSvg(file, chart);
  return true;
}

void EvalStereoReport::WritePlots(const fs::path& dir) const {
  WriteNoiseChart(
      results, "Error vs image noise", "headline bad-pixel % (mean over sets)",
      [&](const std::string& method, const std::string& noise) {
        return MeanPrimary(results, method, noise);
      },
      dir / "noise.svg");
}

}  // namespace linesight
