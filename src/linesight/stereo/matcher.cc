#include "linesight/stereo/matcher.h"

#include <charconv>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <opencv2/imgproc.hpp>

#include "linesight/core/disparity.h"
#include "linesight/core/error.h"
#include "linesight/stereo/algorithm_version.h"
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

std::vector<std::string> MatcherNames() { return {"bm", "sgbm", "sgbm-wls", "sgm", "isgm", "gc"}; }

int MatcherAlgorithmVersion(const std::string& method) {
  // One line per method; see algorithm_version.h for when to bump. OpenCV's methods (bm, sgbm,
  // sgbm-wls) depend on the installed OpenCV too, whose version the cache key records separately.
  static const std::map<std::string, int> kVersions = {{"bm", 1},  {"sgbm", 1}, {"sgbm-wls", 1},
                                                       {"sgm", 1}, {"isgm", 1}, {"gc", 1}};
  const auto it = kVersions.find(method);
  if (it == kVersions.end()) {
    throw UsageError(fmt::format("unknown method '{}' (expected one of: {})", method,
                                 fmt::join(MatcherNames(), ", ")));
  }
  return it->second;
}

std::unique_ptr<StereoMatcher> CreateMatcher(const std::string& method,
                                             const MatcherOptions& options) {
  options.Check();
  MatcherParams params(method, options.params);
  std::unique_ptr<StereoMatcher> matcher;
  if (method == "bm") {
    matcher = CreateOpenCvBlockMatcher(options, params);
  } else if (method == "sgbm") {
    matcher = CreateOpenCvSgbm(options, params);
  } else if (method == "sgbm-wls") {
    matcher = CreateOpenCvSgbmWls(options, params);
  } else if (method == "sgm") {
    matcher = CreateSgmMatcher(options, params);
  } else if (method == "isgm") {
    matcher = CreateIsgmMatcher(options, params);
  } else if (method == "gc") {
    matcher = CreateGraphCutMatcher(options, params);
  } else {
    throw UsageError(fmt::format("unknown method '{}' (expected one of: {})", method,
                                 fmt::join(MatcherNames(), ", ")));
  }
  params.CheckAllUsed();
  return matcher;
}

MatcherParams::MatcherParams(std::string method, std::map<std::string, std::string> params)
    : method_(std::move(method)), params_(std::move(params)) {}

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
  known_.insert(key);
  auto it = params_.find(key);
  return it == params_.end() ? default_value : ParseNumber<int>(method_, key, it->second);
}

double MatcherParams::GetDouble(const std::string& key, double default_value) {
  known_.insert(key);
  auto it = params_.find(key);
  return it == params_.end() ? default_value : ParseNumber<double>(method_, key, it->second);
}

bool MatcherParams::GetBool(const std::string& key, bool default_value) {
  known_.insert(key);
  auto it = params_.find(key);
  if (it == params_.end()) return default_value;
  if (it->second == "1" || it->second == "true" || it->second == "on") return true;
  if (it->second == "0" || it->second == "false" || it->second == "off") return false;
  throw UsageError(fmt::format("{}: parameter '{}' = '{}' is not a boolean (expected true/false)",
                               method_, key, it->second));
}

std::string MatcherParams::GetString(const std::string& key, const std::string& default_value,
                                     const std::vector<std::string>& allowed) {
  known_.insert(key);
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

std::string DefaultMatcherName() {
  const auto names = MatcherNames();
  return std::find(names.begin(), names.end(), "isgm") != names.end() ? "isgm" : "sgbm";
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
