#include "linesight/eval/noise.h"

#include <gtest/gtest.h>

#include "linesight/core/error.h"

namespace linesight {
namespace {

TEST(NoiseSpec, ParsesAndLabels) {
  EXPECT_EQ(NoiseSpec::Parse("clean").kind, NoiseSpec::Kind::kNone);
  const NoiseSpec g = NoiseSpec::Parse("gauss:0.1");
  EXPECT_EQ(g.kind, NoiseSpec::Kind::kGaussian);
  EXPECT_DOUBLE_EQ(g.amount, 0.1);
  EXPECT_EQ(g.Label(), "gauss:0.1");
  EXPECT_EQ(NoiseSpec::Parse("sp:0.35").Label(), "sp:0.35");
}

TEST(NoiseSpec, RejectsMalformed) {
  for (const char* bad :
       {"gauss", "gauss:", "gauss:x", "sp:0", "sp:1.5", "pepper:0.1", "gauss:0.1x"}) {
    EXPECT_THROW(NoiseSpec::Parse(bad), UsageError) << bad;
  }
}

TEST(AddImageNoise, GaussianHasRequestedVarianceAwayFromClipping) {
  cv::Mat grey(200, 201, CV_8UC1, cv::Scalar(128));
  const cv::Mat noisy = AddImageNoise(grey, NoiseSpec::Parse("gauss:0.005"), 1);
  cv::Mat diff;
  noisy.convertTo(diff, CV_64F, 1 / 255.0, -128 / 255.0);
  cv::Scalar mean, stddev;
  cv::meanStdDev(diff, mean, stddev);
  EXPECT_NEAR(mean[0], 0.0, 0.003);
  EXPECT_NEAR(stddev[0] * stddev[0], 0.005, 0.0003);
}

TEST(AddImageNoise, SaltPepperReplacesRequestedFraction) {
  cv::Mat grey(300, 301, CV_8UC3, cv::Scalar(100, 110, 120));
  const cv::Mat noisy = AddImageNoise(grey, NoiseSpec::Parse("sp:0.15"), 2);
  const cv::Mat flat = noisy.reshape(1);
  const double zeros = cv::countNonZero(flat == 0) / static_cast<double>(flat.total());
  const double full = cv::countNonZero(flat == 255) / static_cast<double>(flat.total());
  EXPECT_NEAR(zeros, 0.075, 0.005);
  EXPECT_NEAR(full, 0.075, 0.005);
  const cv::Mat untouched_or_noise =
      (flat == 0) | (flat == 255) | (flat == 100) | (flat == 110) | (flat == 120);
  EXPECT_EQ(cv::countNonZero(untouched_or_noise), static_cast<int>(flat.total()));
}

TEST(AddImageNoise, DeterministicPerSeedAndCleanIsIdentity) {
  cv::Mat img(31, 17, CV_8UC1, cv::Scalar(50));
  const NoiseSpec g = NoiseSpec::Parse("gauss:0.1");
  EXPECT_EQ(cv::norm(AddImageNoise(img, g, 5), AddImageNoise(img, g, 5), cv::NORM_INF), 0);
  EXPECT_GT(cv::norm(AddImageNoise(img, g, 5), AddImageNoise(img, g, 6), cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(AddImageNoise(img, NoiseSpec(), 5), img, cv::NORM_INF), 0);
}

}  // namespace
}  // namespace linesight
