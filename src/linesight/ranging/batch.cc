#include "linesight/ranging/batch.h"

#include <algorithm>
#include <cstdlib>
#include <map>
#include <set>
#include <sstream>

#include <fmt/format.h>

#include "linesight/core/atomic_file.h"
#include "linesight/core/error.h"
#include "linesight/core/progress.h"
#include "linesight/core/timer.h"
#include "linesight/io/image_io.h"
#include "linesight/io/json_io.h"
#include "linesight/io/pfm.h"
#include "linesight/ranging/ranging_settings.h"

namespace linesight {
namespace fs = std::filesystem;

namespace {

fs::path PfmPath(const fs::path& out, const BatchPair& pair) { return out / (pair.name + ".pfm"); }
fs::path JsonPath(const fs::path& out, const BatchPair& pair) {
  return out / (pair.name + ".json");
}
// The report is written last, so it exists only when the pair is complete.
bool HasOutputs(const fs::path& out, const BatchPair& pair) {
  return fs::exists(JsonPath(out, pair)) && fs::exists(PfmPath(out, pair));
}

int ParseShardNumber(const std::string& text, const char* what) {
  size_t used = 0;
  int value = -1;
  try {
    value = std::stoi(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != text.size() || value < 0) {
    throw InputError(fmt::format("{} = '{}': expected a whole number >= 0", what, text));
  }
  return value;
}

// Reads one pair and computes its report and disparity.
class PairProcessor {
 public:
  explicit PairProcessor(const BatchOptions& options) : options_(options) {
    if (options.calibration) {
      pipeline_.emplace(*options.calibration, options.ranging);
    } else {
      matcher_ = CreateMatcher(options.method.empty() ? DefaultMatcherName() : options.method,
                               options.matcher);
    }
  }

  // Writes <out>/<name>.pfm, then <out>/<name>.json.
  void Process(const BatchPair& pair) const {
    const cv::Mat left = ReadImage(pair.left, ImageColor::kColor);
    const cv::Mat right = ReadImage(pair.right, ImageColor::kColor);
    CheckSameSize(left, pair.left, right, pair.right);
    nlohmann::json report{{"name", pair.name},
                          {"left", pair.left_entry},
                          {"right", pair.right_entry},
                          {"width", left.cols},
                          {"height", left.rows}};
    cv::Mat disparity;
    if (pipeline_) {
      CheckCalibrationMatchesImage(*options_.calibration, left.size(), options_.calibration_path);
      const RangingFrame frame = pipeline_->Process(left, right);
      disparity = frame.disparity;
      report.update(RangingChainSettings(*pipeline_));
      report["calibration"] = options_.calibration_path;
      report["obstacles"] = nlohmann::json::array();
      for (const RangeResult& r : pipeline_->RangeAuto(frame)) {
        report["obstacles"].push_back(RangeResultToJson(r));
      }
    } else {
      disparity = matcher_->Compute(left, right).disparity;
      report["method"] = matcher_->Name();
      report["matcher"] = matcher_->Settings();
    }
    report["density"] = DisparityDensity(disparity);
    WritePfm(PfmPath(options_.out, pair), disparity);
    WriteJson(JsonPath(options_.out, pair), report);
  }

 private:
  const BatchOptions& options_;
  std::optional<RangingPipeline> pipeline_;
  std::unique_ptr<StereoMatcher> matcher_;
};

// Appends `pair` after checking that its name makes output files of its own (`where` names the
// manifest line or the glob in the error).
void AddPair(BatchPair pair, const std::string& where, std::vector<BatchPair>* pairs,
             std::set<std::string>* names) {
  if (pair.name.empty() || pair.name.find('/') != std::string::npos || pair.name == "." ||
      pair.name == ".." || pair.name.starts_with("summary")) {
    throw InputError(
        fmt::format("{}: name '{}' cannot name an output file (no '/', not '.', '..' or summary*)",
                    where, pair.name));
  }
  if (!names->insert(pair.name).second) {
    throw InputError(fmt::format(
        "{}: name '{}' is used by an earlier pair (name the pairs in a manifest's third field)",
        where, pair.name));
  }
  pairs->push_back(std::move(pair));
}

}  // namespace

std::vector<BatchPair> ParseBatchManifest(const std::string& text, const fs::path& manifest_path) {
  const fs::path base = manifest_path.parent_path();
  std::vector<BatchPair> pairs;
  std::set<std::string> names;
  std::istringstream lines(text);
  std::string line;
  for (int number = 1; std::getline(lines, line); ++number) {
    const size_t hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    std::istringstream words(line);
    std::vector<std::string> fields;
    for (std::string word; words >> word;) fields.push_back(word);
    if (fields.empty()) continue;
    if (fields.size() < 2 || fields.size() > 3) {
      throw InputError(fmt::format("{}:{}: expected '<left> <right> [<name>]', got {} field(s)",
                                   manifest_path.string(), number, fields.size()));
    }
    BatchPair pair;
    pair.left_entry = fields[0];
    pair.right_entry = fields[1];
    pair.left = (base / fields[0]).lexically_normal();
    pair.right = (base / fields[1]).lexically_normal();
    pair.name = fields.size() == 3 ? fields[2] : fs::path(fields[0]).stem().string();
    AddPair(std::move(pair), fmt::format("{}:{}", manifest_path.string(), number), &pairs, &names);
  }
  if (pairs.empty()) throw InputError(fmt::format("{}: lists no pairs", manifest_path.string()));
  return pairs;
}

std::vector<BatchPair> BatchPairsFromGlobs(const std::string& left_glob,
                                           const std::string& right_glob) {
  const std::vector<fs::path> lefts = ExpandGlob(left_glob), rights = ExpandGlob(right_glob);
  if (lefts.size() != rights.size()) {
    throw InputError(fmt::format("'{}' matches {} files but '{}' matches {}: pairs need one each",
                                 left_glob, lefts.size(), right_glob, rights.size()));
  }
  std::vector<BatchPair> pairs;
  std::set<std::string> names;
  for (size_t i = 0; i < lefts.size(); ++i) {
    AddPair({lefts[i].stem().string(), lefts[i], rights[i], lefts[i].string(), rights[i].string()},
            fmt::format("--left '{}'", left_glob), &pairs, &names);
  }
  return pairs;
}

std::vector<BatchPair> ReadBatchManifest(const fs::path& path) {
  return ParseBatchManifest(ReadTextFile(path), path);
}

BatchShard ParseBatchShard(const std::string& text) {
  const size_t slash = text.find('/');
  BatchShard shard;
  try {
    if (slash == std::string::npos) throw InputError("no '/'");
    shard.index = ParseShardNumber(text.substr(0, slash), "shard index");
    shard.count = ParseShardNumber(text.substr(slash + 1), "shard count");
  } catch (const InputError&) {
    shard.count = 0;
  }
  if (shard.count < 1 || shard.index >= shard.count) {
    throw UsageError(fmt::format("--shard '{}': expected I/N with 0 <= I < N, e.g. 0/4", text));
  }
  return shard;
}

std::optional<BatchShard> BatchShardFromSlurm(
    const std::function<const char*(const char*)>& getenv) {
  const char* id = getenv("SLURM_ARRAY_TASK_ID");
  const char* count = getenv("SLURM_ARRAY_TASK_COUNT");
  if (id == nullptr || count == nullptr) return std::nullopt;
  const char* min = getenv("SLURM_ARRAY_TASK_MIN");
  const char* max = getenv("SLURM_ARRAY_TASK_MAX");
  BatchShard shard;
  const int first = min ? ParseShardNumber(min, "SLURM_ARRAY_TASK_MIN") : 0;
  shard.index = ParseShardNumber(id, "SLURM_ARRAY_TASK_ID") - first;
  shard.count = ParseShardNumber(count, "SLURM_ARRAY_TASK_COUNT");
  const int last = max ? ParseShardNumber(max, "SLURM_ARRAY_TASK_MAX") : first + shard.count - 1;
  if (shard.count < 1 || shard.index < 0 || shard.index >= shard.count ||
      last - first + 1 != shard.count) {
    throw InputError(fmt::format(
        "Slurm array task {} of {} (ids {}..{}) does not make a shard: submit the array as "
        "--array=0-{} (consecutive ids), or give --shard I/N",
        id, count, first, last, shard.count > 0 ? shard.count - 1 : 0));
  }
  return shard;
}

fs::path BatchSummaryPath(const fs::path& out, const BatchShard& shard) {
  if (!shard.sharded()) return out / "summary.json";
  return out / fmt::format("summary.shard-{}-of-{}.json", shard.index, shard.count);
}

nlohmann::json RunBatch(const std::vector<BatchPair>& pairs, const BatchOptions& options,
                        const std::function<void(const nlohmann::json&)>& on_pair) {
  fs::create_directories(options.out);
  const PairProcessor processor(options);  // validates the settings before any pair
  std::vector<size_t> mine;
  for (size_t i = 0; i < pairs.size(); ++i) {
    if (options.shard.Owns(i)) mine.push_back(i);
  }
  Stopwatch total;
  nlohmann::json entries = nlohmann::json::array();
  std::map<std::string, int> counts{{"done", 0}, {"skipped", 0}, {"failed", 0}};
  ProgressBar progress(static_cast<int64_t>(mine.size()), "batch");
  for (const size_t i : mine) {
    const BatchPair& pair = pairs[i];
    nlohmann::json entry{{"name", pair.name}, {"index", i}};
    if (HasOutputs(options.out, pair)) {
      entry["status"] = "skipped";
    } else {
      Stopwatch watch;
      try {
        processor.Process(pair);
        entry["status"] = "done";
      } catch (const std::exception& e) {  // InputError, cv::Exception, a full disk: the pair
        entry["status"] = "failed";
        entry["error"] = e.what();
      }
      entry["ms"] = watch.ElapsedMs();
    }
    ++counts[entry["status"].get<std::string>()];
    progress.Advance(1, pair.name);
    if (on_pair) on_pair(entry);
    entries.push_back(std::move(entry));
  }
  progress.Finish();
  nlohmann::json summary{
      {"out", options.out.string()},
      {"shard", {{"index", options.shard.index}, {"count", options.shard.count}}},
      {"calibration", options.calibration_path},
      {"pairs_in_manifest", pairs.size()},
      {"pairs", entries},
      {"seconds", total.ElapsedMs() / 1000.0}};
  for (const auto& [status, n] : counts) summary[status] = n;
  WriteJson(BatchSummaryPath(options.out, options.shard), summary);
  return summary;
}

nlohmann::json MergeBatchSummaries(const std::vector<BatchPair>& pairs, const fs::path& out) {
  std::map<int, nlohmann::json> shards;
  int count = 0;
  std::error_code error;
  for (const fs::directory_entry& file : fs::directory_iterator(out, error)) {
    int index = 0, n = 0;
    const std::string name = file.path().filename().string();
    if (std::sscanf(name.c_str(), "summary.shard-%d-of-%d.json", &index, &n) != 2) continue;
    if (name != fmt::format("summary.shard-{}-of-{}.json", index, n)) continue;
    if (count != 0 && n != count) {
      throw InputError(
          fmt::format("{}: shard summaries of {} and of {} shards; remove the stale "
                      "ones",
                      out.string(), count, n));
    }
    count = n;
    shards[index] = ReadJson(file.path());
  }
  if (error) throw InputError(fmt::format("{}: {}", out.string(), error.message()));
  if (count == 0) {
    throw InputError(fmt::format("{}: no summary.shard-I-of-N.json to merge", out.string()));
  }
  for (int i = 0; i < count; ++i) {
    if (!shards.contains(i)) {
      throw InputError(
          fmt::format("{}: summary.shard-{}-of-{}.json is missing (has that array "
                      "task run?)",
                      out.string(), i, count));
    }
  }
  std::map<std::string, nlohmann::json> by_name;
  double seconds = 0;
  for (const auto& [index, shard] : shards) {
    seconds += shard.value("seconds", 0.0);
    for (const nlohmann::json& entry : shard.at("pairs")) {
      nlohmann::json e = entry;
      e["shard"] = index;
      by_name[entry.at("name").get<std::string>()] = std::move(e);
    }
  }
  nlohmann::json entries = nlohmann::json::array();
  std::map<std::string, int> counts{{"done", 0}, {"skipped", 0}, {"failed", 0}, {"missing", 0}};
  for (size_t i = 0; i < pairs.size(); ++i) {
    const auto it = by_name.find(pairs[i].name);
    nlohmann::json entry =
        it != by_name.end() ? it->second : nlohmann::json{{"name", pairs[i].name}, {"index", i}};
    if (entry.value("status", "") != "failed" && !HasOutputs(out, pairs[i])) {
      entry["status"] = "missing";
    }
    ++counts[entry["status"].get<std::string>()];
    entries.push_back(std::move(entry));
  }
  nlohmann::json summary{{"out", out.string()},
                         {"merged_shards", count},
                         {"pairs_in_manifest", pairs.size()},
                         {"pairs", entries},
                         {"seconds", seconds}};
  for (const auto& [status, n] : counts) summary[status] = n;
  WriteJson(out / "summary.json", summary);
  return summary;
}

}  // namespace linesight
