#include "linesight/eval/metrics.h"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "linesight/core/error.h"
#include "linesight/eval/eval_test_util.h"

namespace linesight {
namespace {

using test::kInf;
constexpr float kNan = std::numeric_limits<float>::quiet_NaN();

cv::Mat Row(std::initializer_list<float> values) {
  cv::Mat m(1, static_cast<int>(values.size()), CV_32FC1);
  int i = 0;
  for (float v : values) m.at<float>(0, i++) = v;
  return m;
}

// Hand-computed case (errors: 0.5, 0.5, missing, 4, 1; one pixel without ground truth):
//   bad-0.5: errors 4 and 1 (0.5 == tau is good)  -> dense (2 + 1 missing) / 5, sparse 2 / 4
//   bad-1:   error 4 (1 == tau is good)           -> dense 2 / 5, sparse 1 / 4
//   bad-2:   error 4                              -> dense 2 / 5, sparse 1 / 4
//   bad-4:   none (4 == tau is good)              -> dense 1 / 5, sparse 0
//   D1:      error 4 at gt 10 (> 3 and > 0.5)     -> dense 2 / 5, sparse 1 / 4
//   avgerr = (0.5 + 0.5 + 4 + 1) / 4, RMSE = sqrt((0.25 + 0.25 + 16 + 1) / 4)
TEST(DisparityMetrics, HandComputedCase) {
  const cv::Mat gt = Row({1, 2, 3, 10, 20, kInf});
  const cv::Mat d = Row({1.5, 2.5, kInf, 14, 19, 5});
  const DisparityMetrics m = ComputeDisparityMetrics(d, gt);
  EXPECT_EQ(m.evaluated, 5);
  EXPECT_EQ(m.estimated, 4);
  EXPECT_DOUBLE_EQ(m.density, 80.0);
  EXPECT_DOUBLE_EQ(m.bad[0], 60.0);
  EXPECT_DOUBLE_EQ(m.bad[1], 40.0);
  EXPECT_DOUBLE_EQ(m.bad[2], 40.0);
  EXPECT_DOUBLE_EQ(m.bad[3], 20.0);
  EXPECT_DOUBLE_EQ(m.d1, 40.0);
  EXPECT_DOUBLE_EQ(m.bad_sparse[0], 50.0);
  EXPECT_DOUBLE_EQ(m.bad_sparse[1], 25.0);
  EXPECT_DOUBLE_EQ(m.bad_sparse[2], 25.0);
  EXPECT_DOUBLE_EQ(m.bad_sparse[3], 0.0);
  EXPECT_DOUBLE_EQ(m.d1_sparse, 25.0);
  EXPECT_DOUBLE_EQ(m.avgerr, 1.5);
  EXPECT_DOUBLE_EQ(m.rmse, std::sqrt(17.5 / 4));
}

TEST(DisparityMetrics, ErrorEqualToThresholdIsNotBad) {
  const cv::Mat gt = Row({10, 10, 10, 10});
  const DisparityMetrics m = ComputeDisparityMetrics(Row({10.5, 11, 12, 14}), gt);
  // errors 0.5, 1, 2, 4: each equals one threshold exactly and exceeds the smaller ones.
  EXPECT_DOUBLE_EQ(m.bad[0], 75.0);
  EXPECT_DOUBLE_EQ(m.bad[1], 50.0);
  EXPECT_DOUBLE_EQ(m.bad[2], 25.0);
  EXPECT_DOUBLE_EQ(m.bad[3], 0.0);
  // Just above each threshold.
  const DisparityMetrics above =
      ComputeDisparityMetrics(Row({10.5001f, 11.001f, 12.001f, 14.001f}), gt);
  EXPECT_DOUBLE_EQ(above.bad[3], 25.0);
  EXPECT_DOUBLE_EQ(above.bad[0], 100.0);
}

TEST(DisparityMetrics, KittiD1NeedsBothThreeAndFivePercent) {
  // gt 100: e 4 (> 3 but < 5) good, e 6 (> 5) bad; gt 60: e 3 (== 3) good; gt 40: e 4 (> 3, > 2)
  // bad; gt 70: e 3.5 (> 3 but == 3.5 = 5 %) good.
  const cv::Mat gt = Row({100, 100, 60, 40, 70});
  const DisparityMetrics m = ComputeDisparityMetrics(Row({104, 94, 63, 44, 73.5}), gt);
  EXPECT_DOUBLE_EQ(m.d1, 40.0);
  EXPECT_DOUBLE_EQ(m.d1_sparse, 40.0);
}

TEST(DisparityMetrics, MaskSelectsPixelsAndAnyNonZeroCounts) {
  const cv::Mat gt = Row({1, 1, 1, 1});
  const cv::Mat d = Row({1, 3, 1, 3});
  cv::Mat mask = (cv::Mat_<uint8_t>(1, 4) << 255, 128, 0, 0);
  const DisparityMetrics m = ComputeDisparityMetrics(d, gt, mask);
  EXPECT_EQ(m.evaluated, 2);
  EXPECT_DOUBLE_EQ(m.bad[1], 50.0);
  EXPECT_DOUBLE_EQ(m.avgerr, 1.0);
}

TEST(DisparityMetrics, EmptyMaskGivesZeros) {
  const cv::Mat mask(1, 3, CV_8UC1, cv::Scalar(0));
  const DisparityMetrics m = ComputeDisparityMetrics(Row({1, 2, 3}), Row({5, 5, 5}), mask);
  EXPECT_EQ(m.evaluated, 0);
  EXPECT_EQ(m.estimated, 0);
  EXPECT_DOUBLE_EQ(m.density, 0.0);
  EXPECT_DOUBLE_EQ(m.bad[1], 0.0);
  EXPECT_DOUBLE_EQ(m.d1, 0.0);
  EXPECT_DOUBLE_EQ(m.rmse, 0.0);
}

TEST(DisparityMetrics, NoEstimateAtAllIsEntirelyBadWhenDense) {
  const DisparityMetrics m = ComputeDisparityMetrics(Row({kInf, kInf, kNan}), Row({5, 6, 7}));
  EXPECT_EQ(m.evaluated, 3);
  EXPECT_EQ(m.estimated, 0);
  EXPECT_DOUBLE_EQ(m.density, 0.0);
  for (double bad : m.bad) EXPECT_DOUBLE_EQ(bad, 100.0);
  EXPECT_DOUBLE_EQ(m.d1, 100.0);
  for (double bad : m.bad_sparse) EXPECT_DOUBLE_EQ(bad, 0.0);
  EXPECT_DOUBLE_EQ(m.d1_sparse, 0.0);
  EXPECT_DOUBLE_EQ(m.avgerr, 0.0);
  EXPECT_DOUBLE_EQ(m.rmse, 0.0);
}

TEST(DisparityMetrics, NonFiniteGroundTruthIsUnknownAndNonFiniteEstimateIsMissing) {
  const cv::Mat gt = Row({kNan, -kInf, kInf, 2, 2});
  const cv::Mat d = Row({100, 100, 100, -kInf, 2});
  const DisparityMetrics m = ComputeDisparityMetrics(d, gt);
  EXPECT_EQ(m.evaluated, 2);
  EXPECT_EQ(m.estimated, 1);
  EXPECT_DOUBLE_EQ(m.bad[0], 50.0);
  EXPECT_DOUBLE_EQ(m.bad_sparse[0], 0.0);
  EXPECT_DOUBLE_EQ(m.avgerr, 0.0);
}

TEST(DisparityMetrics, WorksOnRegionsOfInterest) {
  cv::Mat gt(4, 4, CV_32FC1, cv::Scalar(8)), d(4, 4, CV_32FC1, cv::Scalar(100));
  d(cv::Rect(1, 1, 2, 2)).setTo(9);  // inside the view: error 1 everywhere
  const DisparityMetrics m =
      ComputeDisparityMetrics(d(cv::Rect(1, 1, 2, 2)), gt(cv::Rect(1, 1, 2, 2)));
  EXPECT_EQ(m.evaluated, 4);
  EXPECT_DOUBLE_EQ(m.avgerr, 1.0);
  EXPECT_DOUBLE_EQ(m.bad[0], 100.0);
  EXPECT_DOUBLE_EQ(m.bad[1], 0.0);
}

TEST(DisparityMetrics, MismatchedInputsAreInputErrors) {
  const cv::Mat gt = Row({1, 2, 3});
  EXPECT_THROW(ComputeDisparityMetrics(Row({1, 2}), gt), InputError);
  EXPECT_THROW(ComputeDisparityMetrics(cv::Mat(1, 3, CV_8UC1, cv::Scalar(1)), gt), InputError);
  EXPECT_THROW(ComputeDisparityMetrics(gt, cv::Mat(1, 3, CV_32FC3)), InputError);
  EXPECT_THROW(ComputeDisparityMetrics(gt, gt, cv::Mat(1, 2, CV_8UC1, cv::Scalar(1))), InputError);
  EXPECT_THROW(ComputeDisparityMetrics(gt, gt, cv::Mat(1, 3, CV_32FC1, cv::Scalar(1))), InputError);
  try {
    ComputeDisparityMetrics(Row({1, 2}), gt);
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(),
                 "disparity map is 2x1 but the ground truth is 3x1 (expected the same size)");
  }
}

TEST(DisparityMetrics, JsonHasTheDocumentedKeys) {
  const DisparityMetrics m =
      ComputeDisparityMetrics(Row({1.5, 2.5, kInf, 14, 19, 5}), Row({1, 2, 3, 10, 20, kInf}));
  const nlohmann::json j = m.ToJson();
  const std::vector<std::string> keys = {
      "evaluated",    "estimated",    "density",   "bad_0.5",        "bad_1",
      "bad_2",        "bad_4",        "d1",        "bad_0.5_sparse", "bad_1_sparse",
      "bad_2_sparse", "bad_4_sparse", "d1_sparse", "avgerr",         "rmse"};
  EXPECT_EQ(j.size(), keys.size());
  for (const std::string& key : keys) EXPECT_TRUE(j.contains(key)) << key;
  EXPECT_EQ(j["evaluated"].get<int64_t>(), 5);
  EXPECT_EQ(j["estimated"].get<int64_t>(), 4);
  EXPECT_DOUBLE_EQ(j["bad_0.5"].get<double>(), 60.0);
  EXPECT_DOUBLE_EQ(j["bad_4_sparse"].get<double>(), 0.0);
  EXPECT_DOUBLE_EQ(j["d1"].get<double>(), 40.0);
  EXPECT_DOUBLE_EQ(j["avgerr"].get<double>(), 1.5);
  EXPECT_EQ(BadKey(0.5), "bad_0.5");
  EXPECT_EQ(BadKey(2.0, true), "bad_2_sparse");
}

TEST(DisparityMetrics, RegionMetricsEvaluateEveryMask) {
  const cv::Mat gt = Row({1, 1, 1, 1});
  const cv::Mat d = Row({1, 3, 1, kInf});
  const std::map<std::string, cv::Mat> masks = {
      {"all", cv::Mat(1, 4, CV_8UC1, cv::Scalar(255))},
      {"nonocc", (cv::Mat_<uint8_t>(1, 4) << 255, 0, 255, 0)}};
  const auto regions = ComputeRegionMetrics(d, gt, masks);
  ASSERT_EQ(regions.size(), 2u);
  EXPECT_DOUBLE_EQ(regions.at("all").bad[1], 50.0);
  EXPECT_DOUBLE_EQ(regions.at("all").density, 75.0);
  EXPECT_DOUBLE_EQ(regions.at("nonocc").bad[1], 0.0);
  EXPECT_EQ(regions.at("nonocc").evaluated, 2);
}

}  // namespace
}  // namespace linesight
