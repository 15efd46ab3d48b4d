// `linesight eval stereo`: runs matchers over benchmark scenes and scores them with the benchmarks'
// metrics.
#pragma once

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "linesight/eval/dataset.h"
#include "linesight/eval/metrics.h"
#include "linesight/eval/noise.h"
#include "linesight/stereo/matcher.h"

namespace linesight {

class ProgressBar;
class ResultCache;

struct EvalStereoOptions {
  std::vector<std::string> methods = {"sgbm"};  // factory names (CreateMatcher)
  // Method parameters: "method.key" applies to that method only, a plain "key" to every method
  // (each method then must know it).
  std::map<std::string, std::string> params;
  int threads = 0;  // matcher threads, 0 = all cores
  // Noise settings; every method runs on every scene at each. Both images get independent noise
  // from a seed derived from `noise_seed`, the scene and the view, so every method sees the same
  // noisy pair.
  std::vector<NoiseSpec> noise = {NoiseSpec()};
  uint64_t noise_seed = 1;
  // If set: <dir>/<set>/<scene>/<method>.pfm (noisy runs:
  // <dir>/<set>/<scene>/<noise>/<method>.pfm).
  std::filesystem::path save_disparity_dir;
  // If set: colour disparity and error maps per scene/method (same folder scheme), and summary
  // plots.
  std::filesystem::path plots_dir;
  // Result cache (result_cache.h); null = none. Every result computed is stored in it; the methods
  // in `cache_read_methods` ("*" = every method, empty = none) take their result from it on an
  // exact key match instead of running (their disparity maps are then not saved or plotted).
  const ResultCache* cache = nullptr;
  std::vector<std::string> cache_read_methods = {"*"};
  // Methods that only come from the cache: a cell without an entry is not run but listed in
  // EvalStereoReport::missing (for a page that must not wait hours for gc).
  std::vector<std::string> cache_only_methods;

  void Check() const;
};

struct EvalStereoResult {
  std::string set, scene, method;
  std::string noise = "clean";  // NoiseSpec::Label()
  int width = 0, height = 0, min_disparity = 0, num_disparities = 0;
  double ms = 0;     // wall time of Compute (one run, includes first-use allocation)
  double mde_s = 0;  // width * height * num_disparities / (ms / 1000) / 1e6
  std::map<std::string, DisparityMetrics>
      regions;  // "nonocc", "all", "disc" where the set has them
  nlohmann::json settings;
  // Set when the result came from a ResultCache: the run that measured it (ms included).
  bool from_cache = false;
  std::string measured_commit, measured_machine, measured_date;
};

// The benchmark's headline figure for a set ("bad-1 nonocc" for Middlebury 2001/2003, "bad-2
// nonocc" for 2005/2006 and 2014, "bad-1 nonocc" for ETH3D, "D1 all" for KITTI, "bad-1 nonocc"
// otherwise).
struct PrimaryMetric {
  std::string label;   // e.g. "bad-2.0 nonocc"
  std::string region;  // e.g. "nonocc"
  double value = 0;    // percent, dense
};
PrimaryMetric PrimaryMetricFor(const EvalStereoResult& result);

// The parameters of `method` from a study's params: "method.key" applies to that method only, a
// plain "key" to every method.
std::map<std::string, std::string> ParamsForMethod(const std::map<std::string, std::string>& params,
                                                   const std::string& method);

// Seed of the noise of one view of one scene (FNV-1a of `key`, e.g. "set/scene/noise/left", mixed
// with `seed`), so that the noise does not depend on the order in which scenes run.
uint64_t NoiseSeedFor(const std::string& key, uint64_t seed);

// Creates every method of a study once with its parameters, so that an unknown method or
// parameter fails (UsageError) before any scene is loaded.
void CheckStudyMethods(const std::vector<std::string>& methods,
                       const std::map<std::string, std::string>& params);

// The matcher options of one study run of `method` over a scene's search range.
MatcherOptions StudyMatcherOptions(const std::string& method, int min_disparity,
                                   int num_disparities, int threads,
                                   const std::map<std::string, std::string>& params);

struct NoisyPair {
  cv::Mat left, right;
};
// `left` and `right` with `noise` added, seeded by NoiseSeedFor(key + "/left" | "/right", seed),
// key = "set/scene/noise".
NoisyPair AddPairNoise(const cv::Mat& left, const cv::Mat& right, const NoiseSpec& noise,
                       const std::string& key, uint64_t seed);

// Line chart of a figure against image noise, one series per method: value(method, noise) gives
// the points. Written to dir/file; false (nothing written) with fewer than two noise settings.
bool WriteNoiseChart(
    const std::vector<EvalStereoResult>& results, const std::string& title,
    const std::string& y_label,
    const std::function<double(const std::string& method, const std::string& noise)>& value,
    const std::filesystem::path& file);

// Markdown table with a row per method and a column per noise setting; value(method, noise) fills
// the cells (two decimals; NaN, a setting the method did not run, prints "–").
std::string MethodByNoiseTable(
    const std::vector<std::string>& methods, const std::vector<std::string>& noises,
    const std::function<double(const std::string& method, const std::string& noise)>& value);

// The scenes of `scenes` whose set is named in `sets` ("*" or an empty list = every scene), in
// their order. Throws InputError naming `what` (e.g. "--noise-sets") when a named set has no scene
// in `scenes`, so a misspelt set fails before anything runs or is written.
std::vector<SceneRef> SelectSets(const std::vector<SceneRef>& scenes,
                                 const std::vector<std::string>& sets, const std::string& what);

// The distinct values of key(result) in first-seen order.
template <typename Key>
std::vector<std::string> UniqueInOrder(const std::vector<EvalStereoResult>& results, Key key) {
  std::vector<std::string> out;
  for (const auto& r : results) {
    std::string k = key(r);
    if (std::find(out.begin(), out.end(), k) == out.end()) out.push_back(std::move(k));
  }
  return out;
}

struct EvalStereoReport {
  std::vector<EvalStereoResult> results;  // scene-major, then method in the requested order
  // Cells of cache_only_methods that had no cache entry, as "set/scene/noise/method".
  std::vector<std::string> missing;
  nlohmann::json ToJson() const;
  // One markdown table per set and noise setting (rows scene x method) followed by the per-set
  // averages per method, and, when several noise settings ran, a method x noise table of the
  // average headline figure.
  std::string ToMarkdown() const;
  // Plots into `dir`: noise.svg (headline error vs noise per method) when several noise settings
  // ran.
  void WritePlots(const std::filesystem::path& dir) const;
};

// Loads each scene, runs every method, computes the metrics. Throws InputError/UsageError for bad
// input (unknown method, unreadable scene). `progress` may be null.
EvalStereoReport RunEvalStereo(const std::vector<SceneRef>& scenes,
                               const EvalStereoOptions& options, ProgressBar* progress = nullptr);

}  // namespace linesight
