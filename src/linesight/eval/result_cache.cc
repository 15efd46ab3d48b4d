#include "linesight/eval/result_cache.h"

#include <cstdio>
#include <ctime>
#include <system_error>
#include <utility>

#include <fmt/format.h>
#include <opencv2/core/version.hpp>

#include "linesight/core/atomic_file.h"
#include "linesight/core/error.h"
#include "linesight/stereo/matcher.h"

namespace linesight {
namespace fs = std::filesystem;

namespace {

constexpr uint64_t kFnvOffset = 1469598103934665603ull;
constexpr uint64_t kFnvPrime = 1099511628211ull;

uint64_t Fnv1a(const void* data, size_t size, uint64_t h) {
  const auto* bytes = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < size; ++i) h = (h ^ bytes[i]) * kFnvPrime;
  return h;
}

// The library's log is stderr (stdout carries reports such as `eval stereo --json -`).
void Warn(const std::string& message) {
  std::fprintf(stderr, "warning: result cache: %s\n", message.c_str());
}

std::string Hex16(uint64_t v) { return fmt::format("{:016x}", v); }

// File-name-safe form of a key component (sets, scenes and noise labels are already safe; this
// guards against a '/' or a leading '.').
std::string SafeName(const std::string& text) {
  std::string out;
  for (char c : text) out += (c == '/' || c == '\\' || c == '\0') ? '_' : c;
  if (out.empty() || out[0] == '.') out.insert(out.begin(), '_');
  return out;
}

EvalStereoResult ResultFromJson(const nlohmann::json& json) {
  EvalStereoResult r;
  r.set = json.at("set").get<std::string>();
  r.scene = json.at("scene").get<std::string>();
  r.method = json.at("method").get<std::string>();
  r.noise = json.at("noise").get<std::string>();
  r.width = json.at("width").get<int>();
  r.height = json.at("height").get<int>();
  r.min_disparity = json.at("min_disparity").get<int>();
  r.num_disparities = json.at("num_disparities").get<int>();
  r.ms = json.at("ms").get<double>();
  r.mde_s = json.at("mde_per_s").get<double>();
  for (const auto& [name, metrics] : json.at("regions").items()) {
    r.regions[name] = DisparityMetrics::FromJson(metrics);
  }
  r.settings = json.at("settings");
  return r;
}

}  // namespace

std::string ImageFingerprint(const cv::Mat& image) {
  const int header[4] = {image.type(), image.rows, image.cols, image.dims};
  uint64_t h = Fnv1a(header, sizeof(header), kFnvOffset);
  const size_t row_bytes = static_cast<size_t>(image.cols) * image.elemSize();
  for (int y = 0; y < image.rows; ++y) h = Fnv1a(image.ptr(y), row_bytes, h);
  return Hex16(h);
}

nlohmann::json MakeResultCacheKey(const StereoScene& scene, const std::string& method,
                                  const nlohmann::json& settings, const NoiseSpec& noise,
                                  uint64_t noise_seed, const cv::Mat& left, const cv::Mat& right) {
  nlohmann::json masks = nlohmann::json::object();
  for (const auto& [name, mask] : scene.masks) masks[name] = ImageFingerprint(mask);
  return {{"set", scene.ref.set},
          {"scene", scene.ref.name},
          {"method", method},
          {"algorithm_version", FindMatcher(method).algorithm_version},
          {"metrics_version", kEvalMetricsVersion},
          {"opencv", CV_VERSION},
          {"settings", settings},
          {"min_disparity", scene.min_disparity},
          {"num_disparities", scene.num_disparities},
          {"noise", noise.Label()},
          // Clean input does not depend on the seed (the fingerprints below cover the input).
          {"noise_seed", noise.kind == NoiseSpec::Kind::kNone ? nlohmann::json(nullptr)
                                                              : nlohmann::json(noise_seed)},
          {"left", ImageFingerprint(left)},
          {"right", ImageFingerprint(right)},
          {"ground_truth", ImageFingerprint(scene.ground_truth)},
          {"masks", masks}};
}

ResultCache::ResultCache(fs::path dir, std::string commit, std::string machine)
    : dir_(std::move(dir)), commit_(std::move(commit)), machine_(std::move(machine)) {}

fs::path ResultCache::PathFor(const nlohmann::json& key) const {
  const std::string text = key.dump();
  const std::string hash = Hex16(Fnv1a(text.data(), text.size(), kFnvOffset));
  return dir_ / SafeName(key.at("set").get<std::string>()) /
         SafeName(key.at("scene").get<std::string>()) /
         SafeName(key.at("method").get<std::string>()) /
         (SafeName(key.at("noise").get<std::string>()) + "-" + hash + ".json");
}

std::optional<EvalStereoResult> ResultCache::Find(const nlohmann::json& key) const {
  const fs::path path = PathFor(key);
  std::error_code error;
  if (!fs::exists(path, error)) return std::nullopt;
  try {
    const nlohmann::json entry = nlohmann::json::parse(ReadTextFile(path));
    if (entry.at("key") != key) {
      // Same hash, other key (a collision or an edited file): not this cell.
      Warn(fmt::format("{} holds another key than its name says; ignored", path.string()));
      return std::nullopt;
    }
    EvalStereoResult result = ResultFromJson(entry.at("result"));
    const nlohmann::json& measured = entry.at("measured");
    result.from_cache = true;
    result.measured_commit = measured.at("commit").get<std::string>();
    result.measured_machine = measured.at("machine").get<std::string>();
    result.measured_date = measured.at("date").get<std::string>();
    return result;
  } catch (const nlohmann::json::exception& e) {
    Warn(fmt::format("ignoring unreadable entry {} ({}); the cell is recomputed", path.string(),
                     e.what()));
  } catch (const InputError& e) {
    Warn(fmt::format("ignoring unreadable entry {} ({}); the cell is recomputed", path.string(),
                     e.what()));
  }
  return std::nullopt;
}

void ResultCache::Store(const nlohmann::json& key, const EvalStereoResult& result) const {
  const fs::path path = PathFor(key);
  std::error_code error;
  fs::create_directories(path.parent_path(), error);
  if (error) {
    throw InputError(fmt::format("result cache: cannot create folder {}: {}",
                                 path.parent_path().string(), error.message()));
  }
  const nlohmann::json entry = {
      {"key", key},
      {"result", EvalStereoResultToJson(result)},
      {"measured", {{"commit", commit_}, {"machine", machine_}, {"date", UtcNowText()}}}};
  WriteTextAtomic(path, entry.dump(1) + "\n");
}

std::string UtcNowText() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char text[64];
  std::strftime(text, sizeof(text), "%Y-%m-%d %H:%M UTC", &tm);
  return text;
}

nlohmann::json EvalStereoResultToJson(const EvalStereoResult& r) {
  nlohmann::json regions = nlohmann::json::object();
  for (const auto& [name, metrics] : r.regions) regions[name] = metrics.ToJson();
  return {{"set", r.set},
          {"scene", r.scene},
          {"method", r.method},
          {"noise", r.noise},
          {"width", r.width},
          {"height", r.height},
          {"min_disparity", r.min_disparity},
          {"num_disparities", r.num_disparities},
          {"ms", r.ms},
          {"mde_per_s", r.mde_s},
          {"regions", regions},
          {"settings", r.settings}};
}

}  // namespace linesight
