#include "linesight/io/disparity_io.h"

#include <cmath>
#include <cstdint>
#include <limits>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "linesight/core/disparity.h"
#include "linesight/io/image_io.h"
#include "linesight/io/io_test_util.h"
#include "linesight/io/pfm.h"

namespace linesight {
namespace {
namespace fs = std::filesystem;
using testing::ExpectInputError;
using testing::SharedData;

class DisparityIoTest : public testing::TempDirTest {};

constexpr float kInf = std::numeric_limits<float>::infinity();

cv::Vec3b Turbo(int level) {
  cv::Mat one(1, 1, CV_8UC1, cv::Scalar(level)), colour;
  cv::applyColorMap(one, colour, cv::COLORMAP_TURBO);
  return colour.at<cv::Vec3b>(0, 0);
}

TEST_F(DisparityIoTest, KittiRoundTripIsBitExactForMultiplesOf1Over256) {
  cv::Mat d(37, 53, CV_32FC1);
  cv::RNG rng(7);
  for (int y = 0; y < d.rows; ++y) {
    for (int x = 0; x < d.cols; ++x)
      d.at<float>(y, x) = static_cast<float>(rng.uniform(1, 65536)) / 256.0f;
  }
  d.at<float>(0, 0) = kInf;
  d.at<float>(3, 4) = kInf;
  d.at<float>(1, 1) = 1.0f / 256;
  d.at<float>(1, 2) = 65535.0f / 256;
  WriteKittiDisparity(dir_ / "d.png", d);
  const cv::Mat back = ReadKittiDisparity(dir_ / "d.png");
  ASSERT_EQ(back.type(), CV_32FC1);
  ASSERT_EQ(back.size(), d.size());
  EXPECT_EQ(std::memcmp(back.data, d.data, d.total() * sizeof(float)), 0);
  // The raw file holds value = d * 256 and 0 for invalid.
  const cv::Mat raw = ReadImage(dir_ / "d.png", ImageColor::kUnchanged);
  ASSERT_EQ(raw.type(), CV_16UC1);
  EXPECT_EQ(raw.at<uint16_t>(0, 0), 0);
  EXPECT_EQ(raw.at<uint16_t>(1, 2), 65535);
  EXPECT_EQ(raw.at<uint16_t>(5, 6), std::lround(d.at<float>(5, 6) * 256));
  EXPECT_EQ(Files(), std::vector<std::string>{"d.png"});
}

TEST_F(DisparityIoTest, KittiWriteRoundsAndClamps) {
  const cv::Mat d = (cv::Mat_<float>(1, 7) << 10.3f, 0.0f, -5.0f, 1000.0f, NAN, -kInf, 0.001f);
  WriteKittiDisparity(dir_ / "d.png", d);
  const cv::Mat raw = ReadImage(dir_ / "d.png", ImageColor::kUnchanged);
  const uint16_t expected[7] = {2637 /* round(10.3 * 256) = round(2636.8) */, 1, 1, 65535, 0, 0, 1};
  for (int x = 0; x < 7; ++x) EXPECT_EQ(raw.at<uint16_t>(0, x), expected[x]) << "x = " << x;
  ExpectInputError([&] { WriteKittiDisparity(dir_ / "d.pfm", d); }, {"d.pfm", ".png"});
  ExpectInputError([&] { WriteKittiDisparity(dir_ / "e.png", cv::Mat(2, 2, CV_64FC1)); },
                   {"CV_32FC1"});
}

TEST_F(DisparityIoTest, KittiRejectsPngsThatAreNot16BitSingleChannel) {
  WriteImage(dir_ / "grey8.png", cv::Mat(4, 4, CV_8UC1, cv::Scalar(9)));
  WriteImage(dir_ / "colour16.png", cv::Mat(4, 4, CV_16UC3, cv::Scalar(9, 9, 9)));
  ExpectInputError([&] { ReadKittiDisparity(dir_ / "grey8.png"); },
                   {"grey8.png", "16-bit single-channel", "got 8-bit with 1 channel"});
  ExpectInputError([&] { ReadKittiDisparity(dir_ / "colour16.png"); },
                   {"colour16.png", "16-bit with 3 channel"});
}

TEST_F(DisparityIoTest, ReadsKitti2015Frame46) {
  const fs::path path = SharedData("kitti-2015/training/disp_occ_0/000046_10.png");
  if (!fs::exists(path)) GTEST_SKIP() << path << " is missing (shared data not installed)";
  const cv::Mat d = ReadDisparity(path);
  ASSERT_EQ(d.type(), CV_32FC1);
  EXPECT_EQ(d.size(), cv::Size(1242, 375));
  const cv::Mat valid = d != kInf;
  double lo = 0, hi = 0;
  cv::minMaxLoc(d, &lo, &hi, nullptr, nullptr, valid);
  EXPECT_NEAR(lo, 4.9, 0.05);
  EXPECT_NEAR(hi, 65.7, 0.05);
  const double known = cv::countNonZero(valid) / static_cast<double>(d.total());
  EXPECT_NEAR(known, 0.12, 0.03);
}

TEST_F(DisparityIoTest, ReadDisparityDispatchesOnExtension) {
  const cv::Mat d = (cv::Mat_<float>(2, 2) << 1.5f, kInf, 3.25f, 4.0f);
  WritePfm(dir_ / "a.pfm", d);
  WritePfm(dir_ / "b.PFM", d);
  WriteKittiDisparity(dir_ / "c.png", d);
  for (const char* name : {"a.pfm", "b.PFM", "c.png"}) {
    const cv::Mat back = ReadDisparity(dir_ / name);
    EXPECT_EQ(std::memcmp(back.data, d.data, 4 * sizeof(float)), 0) << name;
  }
  ExpectInputError([&] { ReadDisparity(dir_ / "d.tiff"); }, {"d.tiff", "'.tiff'", ".pfm"});
  WritePfm(dir_ / "colour.pfm", cv::Mat(2, 2, CV_32FC3, cv::Scalar(1, 2, 3)));
  ExpectInputError([&] { ReadDisparity(dir_ / "colour.pfm"); }, {"colour.pfm", "\"PF\""});
}

TEST(ColorizeDisparityTest, InvalidIsBlackAndRangeMapsToTurboEnds) {
  const cv::Mat d = (cv::Mat_<float>(1, 4) << 10.0f, kInf, 20.0f, 14.0f);
  const cv::Mat colour = ColorizeDisparity(d);
  ASSERT_EQ(colour.type(), CV_8UC3);
  EXPECT_EQ(colour.at<cv::Vec3b>(0, 0), Turbo(0));  // far = dark blue
  EXPECT_EQ(colour.at<cv::Vec3b>(0, 1), cv::Vec3b(0, 0, 0));
  EXPECT_EQ(colour.at<cv::Vec3b>(0, 2), Turbo(255));                        // near = warm
  EXPECT_EQ(colour.at<cv::Vec3b>(0, 3), Turbo(102));                        // (14 - 10) / 10 * 255
  EXPECT_GT(colour.at<cv::Vec3b>(0, 2)[2], colour.at<cv::Vec3b>(0, 2)[0]);  // red > blue
  // An explicit range is used as is; values outside saturate.
  const cv::Mat fixed = ColorizeDisparity(d, 0, 51);
  EXPECT_EQ(fixed.at<cv::Vec3b>(0, 0), Turbo(50));
  EXPECT_EQ(fixed.at<cv::Vec3b>(0, 2), Turbo(100));
  const cv::Mat narrow = ColorizeDisparity(d, 12, 14);
  EXPECT_EQ(narrow.at<cv::Vec3b>(0, 0), Turbo(0));
  EXPECT_EQ(narrow.at<cv::Vec3b>(0, 2), Turbo(255));
}

TEST(ColorizeDisparityTest, DegenerateMaps) {
  const cv::Mat none(3, 3, CV_32FC1, cv::Scalar(kInf));
  EXPECT_EQ(cv::countNonZero(ColorizeDisparity(none).reshape(1)), 0);
  const cv::Mat constant(3, 3, CV_32FC1, cv::Scalar(5));
  EXPECT_EQ(ColorizeDisparity(constant).at<cv::Vec3b>(1, 1), Turbo(0));
  ExpectInputError([&] { ColorizeDisparity(cv::Mat(2, 2, CV_8UC1)); }, {"CV_32FC1"});
  // The legend copes with an empty map and with a tiny one.
  EXPECT_GT(ColorizeDisparityWithLegend(none).rows, 3);
  EXPECT_EQ(ColorizeDisparityWithLegend(constant).cols, 3);
}

TEST(ColorizeDisparityTest, LegendIsAppendedBelowWithBarAndLabels) {
  cv::Mat d(120, 400, CV_32FC1);
  for (int y = 0; y < d.rows; ++y) {
    for (int x = 0; x < d.cols; ++x) d.at<float>(y, x) = 5.0f + 60.0f * x / (d.cols - 1);
  }
  d.at<float>(0, 0) = kInf;
  const cv::Mat plain = ColorizeDisparity(d);
  const cv::Mat legend = ColorizeDisparityWithLegend(d);
  ASSERT_EQ(legend.cols, d.cols);
  ASSERT_GT(legend.rows, d.rows + 15);
  EXPECT_EQ(cv::norm(legend(cv::Rect(0, 0, d.cols, d.rows)), plain, cv::NORM_INF), 0);
  // The bar starts at the colour of the minimum and ends at the colour of the maximum.
  int bar_row = -1;
  for (int y = d.rows; y < legend.rows && bar_row < 0; ++y) {
    if (legend.at<cv::Vec3b>(y, d.cols / 2) != cv::Vec3b(0, 0, 0)) bar_row = y;
  }
  ASSERT_GE(bar_row, 0);
  int left = 0, right = d.cols - 1;
  while (legend.at<cv::Vec3b>(bar_row, left) == cv::Vec3b(0, 0, 0)) ++left;
  while (legend.at<cv::Vec3b>(bar_row, right) == cv::Vec3b(0, 0, 0)) --right;
  EXPECT_EQ(legend.at<cv::Vec3b>(bar_row, left), Turbo(0));
  EXPECT_EQ(legend.at<cv::Vec3b>(bar_row, right), Turbo(255));
  // Tick labels: white-ish text pixels in the bottom part.
  cv::Mat bottom;
  cv::cvtColor(legend(cv::Rect(0, bar_row + 8, d.cols, legend.rows - bar_row - 8)), bottom,
               cv::COLOR_BGR2GRAY);
  EXPECT_GT(cv::countNonZero(bottom > 128), 50);
}

TEST(ColorizeDisparityErrorTest, EncodesErrorAndMissingValues) {
  const cv::Mat gt = (cv::Mat_<float>(1, 5) << 10, 10, 10, kInf, 10);
  const cv::Mat d = (cv::Mat_<float>(1, 5) << 10, 12, 50, 3, kInf);
  const cv::Mat colour = ColorizeDisparityError(d, gt, 5);
  EXPECT_EQ(colour.at<cv::Vec3b>(0, 0), Turbo(0));
  EXPECT_EQ(colour.at<cv::Vec3b>(0, 1), Turbo(102));  // error 2 of 5
  EXPECT_EQ(colour.at<cv::Vec3b>(0, 2), Turbo(255));
  EXPECT_EQ(colour.at<cv::Vec3b>(0, 3), cv::Vec3b(0, 0, 0));        // no ground truth
  EXPECT_EQ(colour.at<cv::Vec3b>(0, 4), cv::Vec3b(255, 255, 255));  // no estimate
  ExpectInputError([&] { ColorizeDisparityError(d, cv::Mat(2, 5, CV_32FC1)); }, {"5x1", "5x2"});
  ExpectInputError([&] { ColorizeDisparityError(d, gt, 0); }, {"max_error"});
}

}  // namespace
}  // namespace linesight
