// Every dense matcher sits behind one interface and is listed in one registry (CONVENTIONS.md §5).
//
// The contract of StereoMatcher::Compute(left, right):
//  * Input: a rectified pair of the same size, 8-bit grey or BGR (anything else is an InputError).
//  * Encoding: MatchResult::disparity is the left view's disparity, CV_32FC1 in pixels, with
//    kInvalidDisparity (+inf, core/disparity.h) where there is no estimate; every finite value lies
//    in [min_disparity, min_disparity + num_disparities - 1]. MatchResult::checked has the same
//    encoding (see there for what it holds).
//  * Every call returns maps of its own: a later call never overwrites an earlier result.
//  * Threads: MatcherOptions::threads sizes the work of one call. Compute never changes the
//    process-wide cv::setNumThreads: matchers that run on OpenCV's thread pool size it for the call
//    only (ScopedOpenCvThreads, core/scoped_threads.h, which restores the caller's setting; with
//    threads = 0 the caller's setting is used), the others run their own std::threads.
//  * Thread safety: MatcherInfo::thread_safe says whether one matcher object may run Compute from
//    several threads at once; otherwise use one object per thread. Calls with threads > 0 of the
//    matchers on OpenCV's pool resize that process-wide pool for their duration, so they must not
//    overlap with each other or with other code that sets it.
#pragma once

#include <map>
#include <memory>
#include <set>
#include <string>
#include <type_traits>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

namespace linesight {

// Options every matcher shares.
struct MatcherOptions {
  int min_disparity = 0;     // smallest disparity searched (px); may be negative
  int num_disparities = 64;  // number of disparities searched (px), any value >= 1
  int threads = 0;           // worker threads; 0 = all hardware threads
  // Method-specific settings as key=value text (from `--param key=value`); every matcher consumes
  // the keys it documents (MatcherInfo::params) and CreateMatcher rejects the rest with a
  // UsageError that lists the documented keys.
  std::map<std::string, std::string> params;

  void Check() const;
};

// What StereoMatcher::Compute returns (encoding: see the contract above).
struct MatchResult {
  cv::Mat disparity;  // the method's output: CV_32FC1 px, +inf = no estimate
  // The disparity before any filling or plane refinement: only pixels the matcher measured and
  // checked itself (same encoding). isgm: its SGM stage's left-right-checked, speckle-filtered and
  // median-filtered map (IsgmResult::sgm.disparity), which the plane refinement then fills. Every
  // other method: the same Mat as `disparity` (same data pointer; see IsSameMapAsDisparity), also
  // sgbm-wls and gc with fill_occlusions, whose filled maps are their checked output.
  cv::Mat checked;

  // True when `checked` is `disparity` itself (every method but isgm).
  bool IsSameMapAsDisparity() const { return checked.data == disparity.data; }
};

class StereoMatcher {
 public:
  virtual ~StereoMatcher() = default;
  // Factory name of the method ("bm", "sgbm", ...).
  virtual std::string Name() const = 0;
  // left/right: rectified pair of the same size, 8-bit grey or BGR; see the contract above.
  virtual MatchResult Compute(const cv::Mat& left, const cv::Mat& right) = 0;
  // All effective settings, for reports and the result cache's key.
  virtual nlohmann::json Settings() const = 0;
};

class MatcherParams;

// One `--param key=value` setting a matcher reads.
struct MatcherParamDoc {
  std::string key;
  // "int", "number", "bool" (true/false, on/off, 1/0), the allowed values as "a|b|c", or "text".
  std::string type;
  std::string default_value;  // the value used when the key is not given, as --param text
  std::string meaning;        // one line
};

// A default value as MatcherParamDoc::default_value text: true / false, or the number as fmt
// prints it.
inline std::string ParamDefault(bool value) { return value ? "true" : "false"; }
template <typename Number>
requires std::is_arithmetic_v<Number> std::string ParamDefault(Number value) {
  return fmt::format("{}", value);
}

using MatcherFactory = std::unique_ptr<StereoMatcher> (*)(const MatcherOptions& options,
                                                          MatcherParams& params);

// One entry of the matcher registry (the table in matcher.cc).
struct MatcherInfo {
  std::string name;         // factory name (--method)
  std::string description;  // one line, for --help
  // Builds the matcher from the shared options and the --param keys it reads from `params`
  // (exactly the keys of `params` below; CreateMatcher rejects the others).
  MatcherFactory create = nullptr;
  std::vector<MatcherParamDoc> params;  // every --param key, in the order they are documented
  // Version of the method's algorithm (>= 1): part of the keys of eval's result cache
  // (eval/result_cache.h), which reuses a stored result only for the same version. BUMP IT
  // WHENEVER A CHANGE ALTERS THE METHOD'S OUTPUT for the same settings and input; changes that
  // keep the output bit-identical (speed-ups checked against the reference) keep it. OpenCV's
  // methods depend on the installed OpenCV too, whose version the cache key records separately.
  int algorithm_version = 1;
  // Whether one matcher object may run Compute from several threads at once (see the contract).
  bool thread_safe = false;
};

// Every matcher, in the order they are documented.
const std::vector<MatcherInfo>& MatcherRegistry();

// The registry entry of `method`; throws UsageError listing the names for an unknown one.
const MatcherInfo& FindMatcher(const std::string& method);

// Creates a matcher by name; throws UsageError for an unknown name or parameter and OptionError for
// an invalid value.
std::unique_ptr<StereoMatcher> CreateMatcher(const std::string& method,
                                             const MatcherOptions& options);

// Names of the registry's matchers, in the order they are documented.
std::vector<std::string> MatcherNames();

// The method used when none is named: "isgm" once it is registered, else "sgbm".
std::string DefaultMatcherName();

// The registry as text for --help: every method with its description, then one line per
// parameter ("key=default (type): meaning").
std::string MatcherHelp();

// Typed access to MatcherOptions::params that remembers which keys were read. Every key read must
// be documented in `docs` with the type of its Get* call (an internal invariant).
class MatcherParams {
 public:
  MatcherParams(std::string method, std::map<std::string, std::string> params,
                std::vector<MatcherParamDoc> docs);
  int GetInt(const std::string& key, int default_value);
  double GetDouble(const std::string& key, double default_value);
  bool GetBool(const std::string& key, bool default_value);
  std::string GetString(const std::string& key, const std::string& default_value,
                        const std::vector<std::string>& allowed = {});
  // Throws UsageError naming any key that no Get* call asked for, and the keys that are valid.
  void CheckAllUsed() const;
  // The keys the Get* calls asked for.
  const std::set<std::string>& read_keys() const { return known_; }

 private:
  // Records `key` as read; checks that it is documented with `type`.
  void Read(const std::string& key, const std::string& type);

  std::string method_;
  std::map<std::string, std::string> params_;
  std::vector<MatcherParamDoc> docs_;
  std::set<std::string> known_;
};

// Converts a fixed-point OpenCV disparity (CV_16S, value = d * 16, anything below min_disparity
// invalid) to our float encoding, keeping only [min_disparity, min_disparity + num_disparities -
// 1].
cv::Mat FixedPointToFloatDisparity(const cv::Mat& fixed16, int min_disparity, int num_disparities);

// Percentage of pixels with a finite disparity.
double DisparityDensity(const cv::Mat& disparity);

// Grey 8-bit view of an input image (BGR is converted, grey is returned as is). Throws InputError
// for other types.
cv::Mat ToGray8(const cv::Mat& image);

}  // namespace linesight
