#include "linesight/rectify/row_alignment.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "linesight/core/error.h"
#include "linesight/core/option_test_util.h"

namespace linesight {
namespace {

// A textured scene at one depth: the right image is the left moved `disparity` px left and
// `row_offset` px down (sub-pixel, bilinear).
std::pair<cv::Mat, cv::Mat> ShiftedPair(double disparity, double row_offset) {
  cv::Mat noise(480, 752, CV_8UC1), left;
  cv::RNG rng(7);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(noise, left, cv::Size(0, 0), 1.5);
  cv::normalize(left, left, 0, 255, cv::NORM_MINMAX);
  const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, -disparity, 0, 1, row_offset);
  cv::Mat right;
  cv::warpAffine(left, right, shift, left.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
  return {left, right};
}

TEST(RowAlignmentOptionsTest, DefaultsAreValid) { EXPECT_NO_THROW(RowAlignmentOptions{}.Check()); }

TEST(RowAlignmentOptionsTest, RejectsEachBoundary) {
  using testing::ExpectCheckRejects;
  ExpectCheckRejects<RowAlignmentOptions>([](auto& o) { o.max_features = 49; });
  ExpectCheckRejects<RowAlignmentOptions>([](auto& o) { o.max_row_offset_px = 0; });
  ExpectCheckRejects<RowAlignmentOptions>([](auto& o) { o.min_matches = 4; });
  ExpectCheckRejects<RowAlignmentOptions>([](auto& o) { o.good_px = 0; });
  ExpectCheckRejects<RowAlignmentOptions>([](auto& o) { o.recalibrate_px = o.good_px; });
}

TEST(RowAlignmentTest, MeasuresTheRowOffsetOfAShiftedPairAndGradesIt) {
  const struct {
    double row_offset;
    RowAlignment::Verdict verdict;
  } cases[] = {{0.0, RowAlignment::Verdict::kGood},
               {-0.3, RowAlignment::Verdict::kGood},
               {0.75, RowAlignment::Verdict::kCheck},
               {1.6, RowAlignment::Verdict::kRecalibrate},
               {-3.0, RowAlignment::Verdict::kRecalibrate}};
  for (const auto& c : cases) {
    const auto [left, right] = ShiftedPair(23.0, c.row_offset);
    const RowAlignment a = MeasureRowAlignment(left, right);
    SCOPED_TRACE(c.row_offset);
    EXPECT_GE(a.matches, 100);
    EXPECT_NEAR(a.median_offset_px, c.row_offset, 0.15);
    EXPECT_NEAR(a.median_abs_offset_px, std::abs(c.row_offset), 0.15);
    EXPECT_GE(a.p90_abs_offset_px, a.median_abs_offset_px);
    EXPECT_EQ(a.verdict, c.verdict) << VerdictName(a.verdict);
  }
}

TEST(RowAlignmentTest, TakesColourImages) {
  const auto [left, right] = ShiftedPair(10.0, 0.0);
  cv::Mat left_bgr, right_bgr;
  cv::cvtColor(left, left_bgr, cv::COLOR_GRAY2BGR);
  cv::cvtColor(right, right_bgr, cv::COLOR_GRAY2BGR);
  EXPECT_EQ(MeasureRowAlignment(left_bgr, right_bgr).verdict, RowAlignment::Verdict::kGood);
}

TEST(RowAlignmentTest, AFeaturelessViewGivesNoVerdictWithItsReason) {
  const cv::Mat flat(480, 752, CV_8UC1, cv::Scalar(128));
  const RowAlignment a = MeasureRowAlignment(flat, flat);
  EXPECT_EQ(a.verdict, RowAlignment::Verdict::kNoVerdict);
  EXPECT_NE(a.reason.find("too little texture"), std::string::npos) << a.reason;
  EXPECT_EQ(a.ToJson()["verdict"], "none");
}

TEST(RowAlignmentTest, RejectsImagesOfDifferentSizes) {
  EXPECT_THROW(MeasureRowAlignment(cv::Mat(10, 10, CV_8UC1), cv::Mat(10, 11, CV_8UC1)), InputError);
}

}  // namespace
}  // namespace linesight
