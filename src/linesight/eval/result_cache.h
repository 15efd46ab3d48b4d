// A result cache for the stereo studies (`eval stereo --cache`, `eval report --cache`), so that a
// study too long for one run (gc under noise: hours) accumulates across runs and machines.
//
// An entry is one (set, scene, method, noise) cell. Its key holds everything the result depends
// on: the method's full effective settings (StereoMatcher::Settings), its algorithm version
// (MatcherInfo::algorithm_version in the matcher registry, bumped by hand when the method's output
// changes), the version of the metrics code, the noise setting and seed, and fingerprints of the
// exact input pair handed to the matcher (noise included), of the ground truth and of every
// evaluation mask. A result is reused only when the stored key equals the key of the run that
// asks, field for field. Each entry also records who measured it (commit, machine, UTC date), so
// that a page built from cached cells can say so.
//
// Layout: <dir>/<set>/<scene>/<method>/<noise>-<16 hex digits of the key's hash>.json, one JSON
// file per entry, written atomically (several processes may fill one cache). An unreadable or
// malformed entry is ignored with a warning on stderr (the run then recomputes and overwrites
// it); it never aborts a study.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "linesight/eval/eval_stereo.h"

namespace linesight {

// Version of the metrics code (ComputeDisparityMetrics, the region masks' use); part of every
// key. Bump it when a metric's definition changes.
inline constexpr int kEvalMetricsVersion = 1;

// The current time as "YYYY-MM-DD HH:MM UTC" (entries' and pages' dates).
std::string UtcNowText();

// The measured fields of one result (set, scene, method, noise, size, range, time, region metrics,
// settings): a cache entry's result and the core of each scene row of `eval stereo --json`.
nlohmann::json EvalStereoResultToJson(const EvalStereoResult& r);

// FNV-1a 64 of an image's type, size and pixel bytes, as 16 hex digits.
std::string ImageFingerprint(const cv::Mat& image);

// The cache key of one cell. `left`/`right` are the images handed to the matcher (after noise).
nlohmann::json MakeResultCacheKey(const StereoScene& scene, const std::string& method,
                                  const nlohmann::json& settings, const NoiseSpec& noise,
                                  uint64_t noise_seed, const cv::Mat& left, const cv::Mat& right);

class ResultCache {
 public:
  // `commit`, `machine`: provenance stored with every entry this cache writes.
  ResultCache(std::filesystem::path dir, std::string commit, std::string machine);

  const std::filesystem::path& dir() const { return dir_; }

  // The cached result of `key` (with from_cache and measured_* set), or nullopt when there is no
  // entry with exactly this key. A corrupt entry is a miss with a warning.
  std::optional<EvalStereoResult> Find(const nlohmann::json& key) const;

  // Stores `result` under `key` (replacing an older entry with the same key). Throws InputError
  // when the folder cannot be written.
  void Store(const nlohmann::json& key, const EvalStereoResult& result) const;

  // Where the entry of `key` lives.
  std::filesystem::path PathFor(const nlohmann::json& key) const;

 private:
  std::filesystem::path dir_;
  std::string commit_, machine_;
};

}  // namespace linesight
