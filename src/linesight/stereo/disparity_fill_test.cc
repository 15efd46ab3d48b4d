#include "linesight/stereo/disparity_fill.h"

#include <cmath>
#include <limits>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core/utility.hpp>

#include "linesight/core/disparity.h"

namespace linesight {
namespace {

constexpr float kInf = kInvalidDisparity;

// Rows: an occlusion between two edges, values on one side only at the row ends, a row without any
// valid pixel, scattered values.
cv::Mat OcclusionRows() {
  return (cv::Mat_<float>(4, 7) << 20, 20, kInf, kInf, kInf, 10, 10,  //
          kInf, kInf, 5, 6, kInf, kInf, kInf,                         //
          kInf, kInf, kInf, kInf, kInf, kInf, kInf,                   //
          3, kInf, 40, kInf, 7, kInf, 8);
}

TEST(FillFromBackground, TakesTheSmallerSideAlongTheRow) {
  cv::Mat d = OcclusionRows();
  EXPECT_EQ(detail::FillFromBackground(&d), 3 + 5 + 7 + 3);
  const cv::Mat expected = (cv::Mat_<float>(4, 7) << 20, 20, 10, 10, 10, 10, 10,  //
                            5, 5, 5, 6, 6, 6, 6,                                  //
                            5, 5, 5, 6, 6, 6, 6,                                  //
                            3, 3, 40, 7, 7, 7, 8);
  EXPECT_EQ(cv::norm(d, expected, cv::NORM_INF), 0.0) << d;
}

TEST(FillFromBackground, EmptyRowsStayInvalidWhenAsked) {
  cv::Mat d = OcclusionRows();
  d.at<float>(2, 3) = std::numeric_limits<float>::quiet_NaN();  // invalid, too
  EXPECT_EQ(detail::FillFromBackground(&d, {.fill_empty_rows = false}), 3 + 5 + 3);
  const cv::Mat expected = (cv::Mat_<float>(4, 7) << 20, 20, 10, 10, 10, 10, 10,  //
                            5, 5, 5, 6, 6, 6, 6,                                  //
                            kInf, kInf, kInf, kInf, kInf, kInf, kInf,             //
                            3, 3, 40, 7, 7, 7, 8);
  // +inf compares equal to +inf; a NaN left behind would not.
  EXPECT_EQ(cv::countNonZero(d != expected), 0) << d;
}

TEST(FillFromBackground, ImageWithoutValidPixels) {
  cv::Mat dense(3, 5, CV_32FC1, cv::Scalar(kInf));
  EXPECT_EQ(detail::FillFromBackground(&dense), 15);
  EXPECT_EQ(cv::countNonZero(dense), 0);
  cv::Mat kept(3, 5, CV_32FC1, cv::Scalar(kInf));
  EXPECT_EQ(detail::FillFromBackground(&kept, {.fill_empty_rows = false}), 0);
  for (int y = 0; y < kept.rows; ++y) {
    for (int x = 0; x < kept.cols; ++x) EXPECT_EQ(kept.at<float>(y, x), kInf);
  }
}

TEST(FillFromBackground, SerialEqualsParallelForAnyThreadCount) {
  cv::RNG rng(5);
  const int saved_threads = cv::getNumThreads();
  for (const double invalid_fraction : {0.0, 0.3, 0.9, 1.0}) {
    cv::Mat src(97, 61, CV_32FC1);
    rng.fill(src, cv::RNG::UNIFORM, 0.0, 64.0);
    for (int y = 0; y < src.rows; ++y) {
      // Some rows entirely invalid, the others at the given density.
      const bool empty_row = y % 11 == 4;
      for (int x = 0; x < src.cols; ++x) {
        if (empty_row || rng.uniform(0.0, 1.0) < invalid_fraction) src.at<float>(y, x) = kInf;
      }
    }
    for (const bool fill_empty_rows : {true, false}) {
      cv::Mat serial = src.clone();
      const int64_t serial_filled = detail::FillFromBackground(
          &serial, {.fill_empty_rows = fill_empty_rows, .parallel = false});
      for (const int threads : {1, 2, 3, 8}) {
        cv::setNumThreads(threads);
        cv::Mat parallel = src.clone();
        EXPECT_EQ(detail::FillFromBackground(&parallel, {.fill_empty_rows = fill_empty_rows}),
                  serial_filled);
        EXPECT_EQ(cv::countNonZero(serial != parallel), 0)
            << "invalid " << invalid_fraction << " fill_empty_rows " << fill_empty_rows
            << " threads " << threads;
      }
      if (fill_empty_rows) {
        for (int y = 0; y < serial.rows; ++y) {
          for (int x = 0; x < serial.cols; ++x) {
            ASSERT_TRUE(IsValidDisparity(serial.at<float>(y, x))) << x << "," << y;
          }
        }
      }
    }
  }
  cv::setNumThreads(saved_threads);
}

}  // namespace
}  // namespace linesight
