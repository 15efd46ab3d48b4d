#include "linesight/stereo/matcher.h"

#include <algorithm>
#include <set>
#include <thread>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <gtest/gtest.h>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "linesight/core/disparity.h"
#include "linesight/core/error.h"
#include "linesight/stereo/isgm.h"
#include "linesight/stereo/sgm.h"

namespace linesight {
namespace {

// A random-texture pair whose right image is the left shifted by `shift` px (constant disparity).
void MakeShiftedPair(int width, int height, int shift, cv::Mat* left, cv::Mat* right) {
  cv::RNG rng(7);
  cv::Mat wide(height, width + shift, CV_8UC1);
  rng.fill(wide, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(wide, wide, cv::Size(3, 3), 0.8);
  // x_right = x_left - shift.
  *left = wide(cv::Rect(0, 0, width, height)).clone();
  *right = wide(cv::Rect(shift, 0, width, height)).clone();
}

TEST(MatcherOptions, DefaultsAreValid) { EXPECT_NO_THROW(MatcherOptions().Check()); }

TEST(MatcherOptions, RejectsZeroDisparities) {
  MatcherOptions o;
  o.num_disparities = 0;
  EXPECT_THROW(o.Check(), OptionError);
}

TEST(CreateMatcher, UnknownMethodIsUsageErrorListingMethods) {
  try {
    CreateMatcher("magic", MatcherOptions());
    FAIL();
  } catch (const UsageError& e) {
    EXPECT_EQ(std::string(e.what()), fmt::format("unknown method 'magic' (expected one of: {})",
                                                 fmt::join(MatcherNames(), ", ")));
  }
  EXPECT_EQ(MatcherNames(),
            (std::vector<std::string>{"bm", "sgbm", "sgbm-wls", "sgm", "isgm", "gc"}));
}

TEST(MatcherRegistry, NamesUniqueAndEveryEntryComplete) {
  std::set<std::string> names;
  for (const MatcherInfo& info : MatcherRegistry()) {
    SCOPED_TRACE(info.name);
    EXPECT_TRUE(names.insert(info.name).second);
    EXPECT_FALSE(info.description.empty());
    EXPECT_EQ(info.description.find('\n'), std::string::npos);  // one line
    ASSERT_NE(info.create, nullptr);
    // eval's result cache keys on it: a method without a version could not be cached.
    EXPECT_GE(info.algorithm_version, 1);
    std::set<std::string> keys;
    for (const MatcherParamDoc& p : info.params) {
      EXPECT_TRUE(keys.insert(p.key).second) << p.key;
      EXPECT_FALSE(p.type.empty() || p.default_value.empty() || p.meaning.empty()) << p.key;
    }
    EXPECT_EQ(&FindMatcher(info.name), &info);
  }
  EXPECT_EQ(MatcherNames().size(), MatcherRegistry().size());
  EXPECT_EQ(DefaultMatcherName(), "isgm");
  EXPECT_THROW(FindMatcher("nonexistent"), UsageError);
}

TEST(MatcherRegistry, EveryMethodIsCreatableWithItsDefaults) {
  for (const std::string& method : MatcherNames()) {
    SCOPED_TRACE(method);
    std::unique_ptr<StereoMatcher> matcher;
    ASSERT_NO_THROW(matcher = CreateMatcher(method, MatcherOptions()));
    EXPECT_EQ(matcher->Name(), method);
    EXPECT_FALSE(matcher->Settings().empty());
  }
}

// The keys the error lists are the keys the matcher reads, and those are exactly the documented
// ones (CreateMatcher also checks this on every creation).
TEST(MatcherRegistry, UnknownParameterErrorListsExactlyTheDocumentedKeys) {
  for (const MatcherInfo& info : MatcherRegistry()) {
    SCOPED_TRACE(info.name);
    std::set<std::string> documented;
    for (const MatcherParamDoc& p : info.params) documented.insert(p.key);
    MatcherOptions o;
    o.params.emplace("no_such_key", "1");
    try {
      CreateMatcher(info.name, o);
      ADD_FAILURE() << "no error";
    } catch (const UsageError& e) {
      EXPECT_EQ(std::string(e.what()),
                fmt::format("unknown parameter 'no_such_key' for method '{}' (valid: {})",
                            info.name, fmt::join(documented, ", ")));
    }
  }
}

// Each documented default is the value the matcher uses without the key, and each documented type
// is how the value is read.
TEST(MatcherRegistry, DocumentedDefaultsAndTypesAreTheMatchersOwn) {
  for (const MatcherInfo& info : MatcherRegistry()) {
    const nlohmann::json defaults = CreateMatcher(info.name, MatcherOptions())->Settings();
    for (const MatcherParamDoc& p : info.params) {
      SCOPED_TRACE(info.name + " " + p.key + "=" + p.default_value);
      MatcherOptions o;
      o.params[p.key] = p.default_value;
      std::unique_ptr<StereoMatcher> matcher;
      ASSERT_NO_THROW(matcher = CreateMatcher(info.name, o));
      EXPECT_EQ(matcher->Settings(), defaults);
      // A value that is not of the documented type is a usage error.
      o.params[p.key] = p.type == "int" ? "1.5" : p.type == "number" ? "1x" : "no_such_value";
      EXPECT_THROW(CreateMatcher(info.name, o), UsageError);
    }
  }
}

TEST(MatcherHelp, ListsEveryMethodAndParameter) {
  const std::string help = MatcherHelp();
  for (const MatcherInfo& info : MatcherRegistry()) {
    EXPECT_NE(help.find(fmt::format("  {}: {}\n", info.name, info.description)), std::string::npos)
        << info.name;
    for (const MatcherParamDoc& p : info.params) {
      EXPECT_NE(
          help.find(fmt::format("    {}={} ({}): {}\n", p.key, p.default_value, p.type, p.meaning)),
          std::string::npos)
          << info.name << " " << p.key;
    }
  }
}

TEST(CreateMatcher, UnknownParameterIsUsageError) {
  MatcherOptions o;
  o.params["blok"] = "5";
  EXPECT_THROW(CreateMatcher("sgbm", o), UsageError);
}

TEST(CreateMatcher, BadParameterValueNamesIt) {
  MatcherOptions o;
  o.params["block"] = "4";
  try {
    CreateMatcher("sgbm", o);
    FAIL();
  } catch (const OptionError& e) {
    EXPECT_STREQ(e.what(), "sgbm.block = 4: must be odd and in [1, 31]");
  }
  o.params["block"] = "five";
  EXPECT_THROW(CreateMatcher("sgbm", o), UsageError);
}

TEST(FixedPointToFloatDisparity, KeepsOnlyRequestedRange) {
  cv::Mat fixed = (cv::Mat_<int16_t>(1, 5) << -16, 32, 40, 16 * 6, 16 * 7);
  cv::Mat d = FixedPointToFloatDisparity(fixed, 2, 5);  // valid [2, 6]
  EXPECT_FALSE(IsValidDisparity(d.at<float>(0)));
  EXPECT_FLOAT_EQ(d.at<float>(1), 2.0f);
  EXPECT_FLOAT_EQ(d.at<float>(2), 2.5f);
  EXPECT_FLOAT_EQ(d.at<float>(3), 6.0f);
  EXPECT_FALSE(IsValidDisparity(d.at<float>(4)));
}

class OpenCvMatcherTest : public ::testing::TestWithParam<std::string> {};

TEST_P(OpenCvMatcherTest, RecoversConstantShiftWithAwkwardRange) {
  cv::Mat left, right;
  MakeShiftedPair(311, 239, 9, &left, &right);
  MatcherOptions o;
  o.num_disparities = 37;  // not a multiple of 16
  auto matcher = CreateMatcher(GetParam(), o);
  cv::Mat d = matcher->Compute(left, right).disparity;
  ASSERT_EQ(d.type(), CV_32FC1);
  ASSERT_EQ(d.size(), left.size());
  int valid = 0, good = 0;
  for (int y = 0; y < d.rows; ++y) {
    for (int x = 0; x < d.cols; ++x) {
      const float v = d.at<float>(y, x);
      if (!IsValidDisparity(v)) continue;
      EXPECT_LE(v, 36.0f);
      ++valid;
      good += std::abs(v - 9.0f) <= 0.5f;
    }
  }
  EXPECT_GT(valid, d.total() / 2);
  EXPECT_GT(good, valid * 95 / 100);
}

TEST_P(OpenCvMatcherTest, DifferentSizesIsInputError) {
  auto matcher = CreateMatcher(GetParam(), MatcherOptions());
  EXPECT_THROW(matcher->Compute(cv::Mat(20, 30, CV_8UC1), cv::Mat(20, 31, CV_8UC1)), InputError);
}

// `threads` sizes OpenCV's pool for the call only: the process-wide setting is the caller's.
TEST(StereoMatcher, ComputeLeavesTheProcessWideThreadCountAlone) {
  cv::Mat left, right;
  MakeShiftedPair(64, 40, 5, &left, &right);
  const int saved = cv::getNumThreads();
  for (const int process_wide : {2, 3}) {
    cv::setNumThreads(process_wide);
    for (const std::string& method : MatcherNames()) {
      for (const int threads : {1, 0}) {
        SCOPED_TRACE(fmt::format("{} threads={} process-wide {}", method, threads, process_wide));
        MatcherOptions options;
        options.num_disparities = 16;
        options.threads = threads;
        CreateMatcher(method, options)->Compute(left, right);
        EXPECT_EQ(cv::getNumThreads(), process_wide);
      }
    }
  }
  cv::setNumThreads(saved);
}

// Every method's MatchResult: float px, +inf or inside the range, checked in the same encoding.
TEST(StereoMatcher, EveryMethodReturnsTheDocumentedEncoding) {
  cv::Mat left, right;
  MakeShiftedPair(80, 48, 7, &left, &right);
  for (const std::string& method : MatcherNames()) {
    SCOPED_TRACE(method);
    MatcherOptions options;
    options.min_disparity = 2;
    options.num_disparities = 13;
    options.threads = 1;
    const MatchResult r = CreateMatcher(method, options)->Compute(left, right);
    for (const cv::Mat* map : {&r.disparity, &r.checked}) {
      ASSERT_EQ(map->type(), CV_32FC1);
      ASSERT_EQ(map->size(), left.size());
      int outside = 0, valid = 0;
      for (int y = 0; y < map->rows; ++y) {
        for (int x = 0; x < map->cols; ++x) {
          const float d = map->at<float>(y, x);
          if (!IsValidDisparity(d)) {
            EXPECT_EQ(d, kInvalidDisparity);
            continue;
          }
          ++valid;
          outside += d < 2.0f || d > 14.0f;
        }
      }
      EXPECT_EQ(outside, 0);
      EXPECT_GT(valid, 0);
    }
  }
}

// isgm's `checked` is its SGM stage's map before the plane refinement fills it; for sgm (and
// every other method) it is the disparity itself.
TEST(MatchResult, CheckedIsTheSgmStageForIsgmAndTheDisparityElsewhere) {
  cv::Mat left, right;
  MakeShiftedPair(96, 64, 6, &left, &right);
  MatcherOptions options;
  options.num_disparities = 16;
  const MatchResult isgm = CreateMatcher("isgm", options)->Compute(left, right);
  EXPECT_FALSE(isgm.IsSameMapAsDisparity());
  EXPECT_EQ(DisparityDensity(isgm.disparity), 100.0);  // dense after the refinement
  EXPECT_LT(DisparityDensity(isgm.checked), 100.0);    // the left image's border has no match
  // The same map as ComputeDetailed's sgm.disparity and as SGM with isgm's SGM settings.
  MatcherParams params("isgm", {}, IsgmParamDocs());
  IsgmMatcher detailed(ReadIsgmOptions(options, params));
  const IsgmResult full = detailed.ComputeDetailed(left, right);
  const cv::Mat sgm_stage = SgmMatcher(detailed.options().sgm).Compute(left, right).disparity;
  EXPECT_EQ(cv::countNonZero(isgm.checked != full.sgm.disparity), 0);
  EXPECT_EQ(cv::countNonZero(isgm.checked != sgm_stage), 0);
  EXPECT_EQ(cv::countNonZero(isgm.disparity != full.disparity), 0);

  for (const std::string& method : MatcherNames()) {
    if (method == "isgm") continue;
    SCOPED_TRACE(method);
    const MatchResult r = CreateMatcher(method, options)->Compute(left, right);
    EXPECT_TRUE(r.IsSameMapAsDisparity());
    EXPECT_EQ(r.checked.size(), r.disparity.size());
  }
}

// A method marked thread_safe gives, from several threads at once on one object, what it gives
// serially.
TEST(MatcherRegistry, ThreadSafeMethodsMatchConcurrently) {
  cv::Mat left, right;
  MakeShiftedPair(64, 40, 5, &left, &right);
  int tested = 0;
  for (const MatcherInfo& info : MatcherRegistry()) {
    if (!info.thread_safe) continue;
    SCOPED_TRACE(info.name);
    ++tested;
    MatcherOptions options;
    options.num_disparities = 16;
    options.threads = 1;
    auto matcher = CreateMatcher(info.name, options);
    const cv::Mat serial = matcher->Compute(left, right).disparity;
    std::vector<cv::Mat> results(3);
    std::vector<std::thread> workers;
    for (size_t i = 0; i < results.size(); ++i) {
      workers.emplace_back([&, i] { results[i] = matcher->Compute(left, right).disparity; });
    }
    for (std::thread& worker : workers) worker.join();
    for (const cv::Mat& result : results) {
      ASSERT_EQ(result.size(), serial.size());
      EXPECT_EQ(cv::countNonZero(result != serial), 0);
    }
  }
  EXPECT_GE(tested, 1);  // gc
}

INSTANTIATE_TEST_SUITE_P(Methods, OpenCvMatcherTest, ::testing::Values("bm", "sgbm", "sgbm-wls"));

}  // namespace
}  // namespace linesight
