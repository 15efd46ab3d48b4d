// Every dense matcher sits behind one interface with a factory by name (CONVENTIONS.md §5).
#pragma once

#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

namespace linesight {

// Options every matcher shares.
struct MatcherOptions {
  int min_disparity = 0;     // smallest disparity searched (px); may be negative
  int num_disparities = 64;  // number of disparities searched (px), any value >= 1
  int threads = 0;           // worker threads; 0 = all hardware threads
  // Method-specific settings as key=value text (from `--param key=value`); every matcher consumes
  // the keys it knows and rejects the rest with a UsageError that lists the valid keys.
  std::map<std::string, std::string> params;

  void Check() const;
};

class StereoMatcher {
 public:
  virtual ~StereoMatcher() = default;
  // Factory name of the method ("bm", "sgbm", ...).
  virtual std::string Name() const = 0;
  // left/right: rectified pair of the same size, 8-bit grey or BGR. Returns the left disparity as
  // CV_32FC1 in pixels with +inf where there is no estimate. Only values in [min_disparity,
  // min_disparity + num_disparities - 1] are returned.
  virtual cv::Mat Compute(const cv::Mat& left, const cv::Mat& right) = 0;
  // All effective settings, for reports.
  virtual nlohmann::json Settings() const = 0;
};

// Creates a matcher by name; throws UsageError for an unknown name or parameter and OptionError for
// an invalid value.
std::unique_ptr<StereoMatcher> CreateMatcher(const std::string& method,
                                             const MatcherOptions& options);

// Names accepted by CreateMatcher, in the order they are documented.
std::vector<std::string> MatcherNames();

// Typed access to MatcherOptions::params that remembers which keys were read.
class MatcherParams {
 public:
  MatcherParams(std::string method, std::map<std::string, std::string> params);
  int GetInt(const std::string& key, int default_value);
  double GetDouble(const std::string& key, double default_value);
  bool GetBool(const std::string& key, bool default_value);
  std::string GetString(const std::string& key, const std::string& default_value,
                        const std::vector<std::string>& allowed = {});
  // Throws UsageError naming any key that no Get* call asked for, and the keys that are valid.
  void CheckAllUsed() const;

 private:
  std::string method_;
  std::map<std::string, std::string> params_;
  std::set<std::string> known_;
};

// Converts a fixed-point OpenCV disparity (CV_16S, value = d * 16, anything below min_disparity
// invalid) to our float encoding, keeping only [min_disparity, min_disparity + num_disparities -
// 1].
cv::Mat FixedPointToFloatDisparity(const cv::Mat& fixed16, int min_disparity, int num_disparities);

// Percentage of pixels with a finite disparity.
double DisparityDensity(const cv::Mat& disparity);

// The method used when none is named: "isgm" once it is registered, else "sgbm".
std::string DefaultMatcherName();

// Grey 8-bit view of an input image (BGR is converted, grey is returned as is). Throws InputError
// for other types.
cv::Mat ToGray8(const cv::Mat& image);

}  // namespace linesight
