#include "linesight/stereo/matcher.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "linesight/core/disparity.h"
#include "linesight/core/error.h"
#include "linesight/stereo/algorithm_version.h"

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
    EXPECT_NE(std::string(e.what()).find("unknown method 'magic'"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("sgbm"), std::string::npos);
  }
}

TEST(MatcherAlgorithmVersion, EveryMethodHasOneAndUnknownIsUsageError) {
  // eval's result cache keys on it: a method without a version could not be cached.
  for (const std::string& method : MatcherNames()) EXPECT_GE(MatcherAlgorithmVersion(method), 1);
  EXPECT_THROW(MatcherAlgorithmVersion("nonexistent"), UsageError);
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
  cv::Mat d = matcher->Compute(left, right);
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
  cv::setNumThreads(2);
  for (const std::string method : {"bm", "sgbm", "sgbm-wls", "isgm"}) {
    SCOPED_TRACE(method);
    MatcherOptions options;
    options.num_disparities = 16;
    options.threads = 1;
    CreateMatcher(method, options)->Compute(left, right);
    EXPECT_EQ(cv::getNumThreads(), 2);
  }
  cv::setNumThreads(saved);
}

INSTANTIATE_TEST_SUITE_P(Methods, OpenCvMatcherTest, ::testing::Values("bm", "sgbm", "sgbm-wls"));

}  // namespace
}  // namespace linesight
