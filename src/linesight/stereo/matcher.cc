#include "linesight/stereo/matcher.h"

#include <algorithm>
#include <charconv>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <opencv2/imgproc.hpp>

#include "linesight/core/disparity.h"
#include "linesight/core/error.h"
#include "linesight/core/key_value.h"
#include "linesight/stereo/graph_cut.h"
#include "linesight/stereo/isgm.h"
#include "linesight/stereo/opencv_matchers.h"
#include "linesight/stereo/sgm.h"

namespace linesight {

void MatcherOptions::Check() const {
  CheckOption(num_disparities >= 1, "MatcherOptions.num_disparities", num_disparities,
              "must be >= 1");
  CheckOption(num_disparities <= 1024, "MatcherOptions.num_disparities", num_disparities,
              "must be <= 1024");
  CheckOption(min_disparity > -1024 && min_disparity < 4096, "MatcherOptions.min_disparity",
              min_disparity, "must be in (-1024, 4096)");
  CheckOption(threads >= 0, "MatcherOptions.threads", threads, "must be >= 0 (0 = all cores)");
}

const std::vector<MatcherInfo>& MatcherRegistry() {
  // The one list of matchers (CONVENTIONS.md §5), in documentation order. An explicit table rather
  // than self-registering statics, which a static library drops when nothing references them.
  // algorithm_version: see MatcherInfo before changing a method's output.
  static const std::vector<MatcherInfo> kRegistry = {
      {"bm", "OpenCV StereoBM block matching (fast, sparse)", CreateOpenCvBlockMatcher,
       OpenCvBlockMatcherParamDocs(), /*algorithm_version=*/1, /*thread_safe=*/false},
      {"sgbm", "OpenCV StereoSGBM semi-global block matching", CreateOpenCvSgbm,
       OpenCvSgbmParamDocs(), /*algorithm_version=*/1, /*thread_safe=*/false},
      {"sgbm-wls", "OpenCV StereoSGBM + ximgproc DisparityWLSFilter (dense, edge-aware)",
       CreateOpenCvSgbmWls, OpenCvSgbmWlsParamDocs(), /*algorithm_version=*/1,
       /*thread_safe=*/false},
      {"sgm", "linesight semi-global matching: census cost, 8 or 4 paths, left-right check",
       CreateSgmMatcher, SgmParamDocs(), /*algorithm_version=*/1, /*thread_safe=*/false},
      {"isgm", "linesight SGM refined by robust planes in superpixels (100 % dense)",
       CreateIsgmMatcher, IsgmParamDocs(), /*algorithm_version=*/1, /*thread_safe=*/false},
      {"gc", "graph cuts: Potts energy by alpha-expansion (the slow global baseline)",
       CreateGraphCutMatcher, GraphCutParamDocs(), /*algorithm_version=*/1, /*thread_safe=*/true},
  };
  return kRegistry;
}

const MatcherInfo& FindMatcher(const std::string& method) {
  for (const MatcherInfo& info : MatcherRegistry()) {
    if (info.name == method) return info;
  }
  throw UsageError(fmt::format("unknown method '{}' (expected one of: {})", method,
                               fmt::join(MatcherNames(), ", ")));
}

std::vector<std::string> MatcherNames() {
  std::vector<std::string> names;
  for (const MatcherInfo& info : MatcherRegistry()) names.push_back(info.name);
  return names;
}

std::string DefaultMatcherName() {
  const auto names = MatcherNames();
  return std::find(names.begin(), names.end(), "isgm") != names.end() ? "isgm" : "sgbm";
}

std::string MatcherHelp() {
  std::string text = "Methods (--method) and their parameters (--param key=value):\n";
  for (const MatcherInfo& info : MatcherRegistry()) {
    text += fmt::format("  {}: {}\n", info.name, info.description);
    for (const MatcherParamDoc& p : info.params) {
      text += fmt::format("    {}={} ({}): {}\n", p.key, p.default_value, p.type, p.meaning);
    }
  }
  return text;
}

std::unique_ptr<StereoMatcher> CreateMatcher(const std::string& method,
                                             const MatcherOptions& options) {
  options.Check();
  const MatcherInfo& info = FindMatcher(method);
  MatcherParams params(method, options.params, info.params);
  std::unique_ptr<StereoMatcher> matcher = info.create(options, params);
  // Every documented key is read (MatcherParams checks the converse on every read).
  LS_CHECK_MSG(params.read_keys().size() == info.params.size(),
               "{} reads {} --param keys but documents {}", method, params.read_keys().size(),
               info.params.size());
  params.CheckAllUsed();
  return matcher;
}

MatcherParams::MatcherParams(std::string method, std::map<std::string, std::string> params,
                             std::vector<MatcherParamDoc> docs)
    : method_(std::move(method)), params_(std::move(params)), docs_(std::move(docs)) {}

void MatcherParams::Read(const std::string& key, const std::string& type) {
  const auto doc = std::find_if(docs_.begin(), docs_.end(),
                                [&](const MatcherParamDoc& d) { return d.key == key; });
  LS_CHECK_MSG(doc != docs_.end(), "{} reads the undocumented --param key '{}'", method_, key);
  LS_CHECK_MSG(doc->type == type, "{}: --param key '{}' is read as {} but documented as {}",
               method_, key, type, doc->type);
  known_.insert(key);
}

namespace {
template <typename T>
T ParseNumber(const std::string& method, const std::string& key, const std::string& text) {
  T value{};
  const char* end = text.data() + text.size();
  auto [ptr, ec] = std::from_chars(text.data(), end, value);
  if (ec != std::errc() || ptr != end) {
    throw UsageError(fmt::format("{}: parameter '{}' = '{}' is not a valid {}", method, key, text,
                                 std::is_integral_v<T> ? "integer" : "number"));
  }
  return value;
}
}  // namespace

int MatcherParams::GetInt(const std::string& key, int default_value) {
  Read(key, "int");
  auto it = params_.find(key);
  return it == params_.end() ? default_value : ParseNumber<int>(method_, key, it->second);
}

double MatcherParams::GetDouble(const std::string& key, double default_value) {
  Read(key, "number");
  auto it = params_.find(key);
  return it == params_.end() ? default_value : ParseNumber<double>(method_, key, it->second);
}

bool MatcherParams::GetBool(const std::string& key, bool default_value) {
  Read(key, "bool");
  auto it = params_.find(key);
  if (it == params_.end()) return default_value;
  bool value = false;
  if (detail::ParseBoolText(it->second, &value)) return value;
  throw UsageError(fmt::format("{}: parameter '{}' = '{}' is not a boolean (expected true/false)",
                               method_, key, it->second));
}

std::string MatcherParams::GetString(const std::string& key, const std::string& default_value,
                                     const std::vector<std::string>& allowed) {
  Read(key, allowed.empty() ? "text" : fmt::format("{}", fmt::join(allowed, "|")));
  auto it = params_.find(key);
  if (it == params_.end()) return default_value;
  if (!allowed.empty() && std::find(allowed.begin(), allowed.end(), it->second) == allowed.end()) {
    throw UsageError(fmt::format("{}: parameter '{}' = '{}' is not one of: {}", method_, key,
                                 it->second, fmt::join(allowed, ", ")));
  }
  return it->second;
}

void MatcherParams::CheckAllUsed() const {
  for (const auto& [key, value] : params_) {
    if (!known_.count(key)) {
      throw UsageError(fmt::format("unknown parameter '{}' for method '{}' (valid: {})", key,
                                   method_, fmt::join(known_, ", ")));
    }
  }
}

cv::Mat FixedPointToFloatDisparity(const cv::Mat& fixed16, int min_disparity, int num_disparities) {
  LS_CHECK(fixed16.type() == CV_16SC1);
  cv::Mat out(fixed16.size(), CV_32FC1);
  const int lo = min_disparity * 16;
  const int hi = (min_disparity + num_disparities - 1) * 16;
  for (int y = 0; y < fixed16.rows; ++y) {
    const int16_t* src = fixed16.ptr<int16_t>(y);
    float* dst = out.ptr<float>(y);
    for (int x = 0; x < fixed16.cols; ++x) {
      const int v = src[x];
      dst[x] = (v < lo || v > hi) ? kInvalidDisparity : static_cast<float>(v) / 16.0f;
    }
  }
  return out;
}

double DisparityDensity(const cv::Mat& disparity) {
  LS_CHECK(disparity.type() == CV_32FC1);
  if (disparity.empty()) return 0;
  int64_t valid = 0;
  for (int y = 0; y < disparity.rows; ++y) {
    const float* row = disparity.ptr<float>(y);
    for (int x = 0; x < disparity.cols; ++x) valid += IsValidDisparity(row[x]);
  }
  return 100.0 * static_cast<double>(valid) / static_cast<double>(disparity.total());
}

cv::Mat ToGray8(const cv::Mat& image) {
  if (image.depth() != CV_8U) {
    throw InputError(fmt::format("matcher input must be 8-bit, got depth {}", image.depth()));
  }
  if (image.channels() == 1) return image;
  cv::Mat gray;
  if (image.channels() == 3) {
    cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  } else if (image.channels() == 4) {
    cv::cvtColor(image, gray, cv::COLOR_BGRA2GRAY);
  } else {
    throw InputError(
        fmt::format("matcher input must have 1, 3 or 4 channels, got {}", image.channels()));
  }
  return gray;
}

}  // namespace linesight
