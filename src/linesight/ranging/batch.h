// Batch re-processing: many recorded pairs in one process, resumable, shardable over a cluster.
//
// A manifest lists the pairs, one per line: `<left> <right> [<name>]` separated by white space;
// `#` starts a comment, blank lines are ignored, relative paths are relative to the manifest's
// folder and the name defaults to the left file's stem. Each pair gets `<out>/<name>.pfm` (its
// disparity) and `<out>/<name>.json` (its report); both are written atomically and depend only on
// the pair and the settings, never on which process or shard made them, so a finished pair is
// recognised by its outputs and skipped when the batch runs again.
//
// Sharding: pair i belongs to shard i mod N. Each shard writes `<out>/summary.shard-I-of-N.json`;
// an unsharded run writes `<out>/summary.json`, and MergeBatchSummaries turns the shard summaries
// into the same `<out>/summary.json`.
#pragma once
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "linesight/io/stereo_calibration.h"
#include "linesight/ranging/pipeline.h"
#include "linesight/stereo/matcher.h"

namespace linesight {

struct BatchPair {
  std::string name;                     // output stem: <out>/<name>.pfm and <out>/<name>.json
  std::filesystem::path left, right;    // resolved against the manifest's folder
  std::string left_entry, right_entry;  // as the manifest writes them (recorded in the reports)
};

// Reads a manifest (format above). Throws InputError naming the file and line for a malformed
// line, an empty manifest or a name used twice.
std::vector<BatchPair> ReadBatchManifest(const std::filesystem::path& path);
std::vector<BatchPair> ParseBatchManifest(const std::string& text,
                                          const std::filesystem::path& manifest_path);

// The pairs of two globs (ExpandGlob), matched in sorted order, named by the left files' stems.
// Throws InputError when the globs match different numbers of files or a name repeats.
std::vector<BatchPair> BatchPairsFromGlobs(const std::string& left_glob,
                                           const std::string& right_glob);

// One shard of N: pairs whose index i has i mod count == index.
struct BatchShard {
  int index = 0;
  int count = 1;
  bool sharded() const { return count > 1; }
  bool Owns(size_t pair_index) const {
    return static_cast<int>(pair_index % static_cast<size_t>(count)) == index;
  }
};
// Parses "I/N" (0 <= I < N); throws UsageError otherwise.
BatchShard ParseBatchShard(const std::string& text);
// The shard of a Slurm array task: SLURM_ARRAY_TASK_ID - SLURM_ARRAY_TASK_MIN of
// SLURM_ARRAY_TASK_COUNT, read through `getenv`; nullopt outside an array job. Throws InputError
// for values that do not make a shard (e.g. an array with steps, `--array=0-6:2`).
std::optional<BatchShard> BatchShardFromSlurm(
    const std::function<const char*(const char*)>& getenv);

struct BatchOptions {
  std::filesystem::path out;  // output folder (created if missing)
  // With a calibration the pairs are raw (or rectified, ranging.input_rectified): each is
  // rectified, matched over the working range and its obstacles are found (`range --auto`).
  // Without one each pair is a rectified pair and only matched (`disparity`).
  std::optional<StereoCalibration> calibration;
  std::string calibration_path;    // as given, recorded in the reports
  RangingPipelineOptions ranging;  // with a calibration
  std::string method;              // without one: matcher name (empty = the default)
  MatcherOptions matcher;          //   and its options
  BatchShard shard;
};

// Processes this shard's pairs that have no outputs yet and returns its summary (also written to
// <out>/summary[.shard-I-of-N].json): one entry per pair of the shard with its status ("done",
// "skipped" or "failed" with the error), then counts and timings. A pair that fails does not stop
// the others. `on_pair` (optional) is called after each pair with the pair's summary entry.
nlohmann::json RunBatch(const std::vector<BatchPair>& pairs, const BatchOptions& options,
                        const std::function<void(const nlohmann::json&)>& on_pair = {});

// Path of a shard's (or, unsharded, the batch's) summary in `out`.
std::filesystem::path BatchSummaryPath(const std::filesystem::path& out, const BatchShard& shard);

// Merges the shard summaries found in `out` into <out>/summary.json (and returns it): every pair
// of the manifest in manifest order with its shard's status. Throws InputError when a shard's
// summary is missing or the shards disagree on N; a pair without its outputs is reported as
// "missing".
nlohmann::json MergeBatchSummaries(const std::vector<BatchPair>& pairs,
                                   const std::filesystem::path& out);

}  // namespace linesight
