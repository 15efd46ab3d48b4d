#include "linesight/geometry/depth.h"

#include <filesystem>

#include <gtest/gtest.h>

#include "linesight/core/disparity.h"
#include "linesight/core/error.h"

namespace linesight {
namespace {

StereoCalibration RectifiedRig(double f, double cx, double cy, double baseline,
                               double doffs = 0.0) {
  StereoCalibration c;
  c.image_size = {64, 48};
  c.Q = (cv::Mat_<double>(4, 4) << 1, 0, 0, -cx, 0, 1, 0, -cy, 0, 0, 0, f, 0, 0, 1.0 / baseline,
         doffs / baseline);
  return c;
}

TEST(GeometryTest, ReadsFocalBaselineAndOffsetFromQ) {
  const StereoGeometry g = GeometryFromCalibration(RectifiedRig(736.0, 376.0, 240.0, 0.119, 3.5));
  EXPECT_DOUBLE_EQ(g.focal_px, 736.0);
  EXPECT_NEAR(g.baseline_m, 0.119, 1e-12);
  EXPECT_NEAR(g.disparity_offset_px, 3.5, 1e-12);
  EXPECT_DOUBLE_EQ(g.cx, 376.0);
  EXPECT_DOUBLE_EQ(g.cy, 240.0);
  // 736 * 0.119 / (20 + 3.5) = 3.72697...
  EXPECT_NEAR(g.DepthFromDisparity(20.0), 736.0 * 0.119 / 23.5, 1e-12);
  EXPECT_NEAR(g.DisparityFromDepth(g.DepthFromDisparity(20.0)), 20.0, 1e-12);
  // sigma_Z = Z^2 sigma_d / (f B): at Z = 2 m, sigma_d = 0.1 px -> 4 * 0.1 / 87.584 = 4.567 mm.
  EXPECT_NEAR(g.DepthSigma(2.0, 0.1), 0.4 / (736.0 * 0.119), 1e-12);
}

TEST(GeometryTest, RejectsBadQ) {
  StereoCalibration c = RectifiedRig(700, 320, 240, 0.1);
  c.Q.at<double>(3, 2) = -10.0;  // negative baseline
  EXPECT_THROW(GeometryFromCalibration(c), InputError);
  c.Q.at<double>(3, 2) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(GeometryFromCalibration(c), InputError);
  c.Q = cv::Mat();
  EXPECT_THROW(GeometryFromCalibration(c), InputError);
}

TEST(GeometryTest, DepthAndPointsOfAKnownDisparity) {
  const StereoCalibration c = RectifiedRig(700.0, 32.0, 24.0, 0.1, 2.0);
  const StereoGeometry g = GeometryFromCalibration(c);
  cv::Mat disparity(48, 64, CV_32F, cv::Scalar(33.0f));
  disparity.at<float>(5, 7) = kInvalidDisparity;
  disparity.at<float>(6, 7) = -2.5f;  // d + doffs < 0: behind the camera, no depth
  const cv::Mat depth = DepthFromDisparity(disparity, g);
  EXPECT_NEAR(depth.at<float>(10, 10), 70.0 / 35.0, 1e-6);
  EXPECT_EQ(depth.at<float>(5, 7), kNoDepth);
  EXPECT_EQ(depth.at<float>(6, 7), kNoDepth);
  const cv::Mat points = PointsFromDisparity(disparity, c.Q);
  const cv::Vec3f p =
      points.at<cv::Vec3f>(40, 50);  // Z = 2 m; X = (50-32)*2/700; Y = (40-24)*2/700
  EXPECT_NEAR(p[2], 2.0, 1e-6);
  EXPECT_NEAR(p[0], 18.0 * 2.0 / 700.0, 1e-6);
  EXPECT_NEAR(p[1], 16.0 * 2.0 / 700.0, 1e-6);
  EXPECT_TRUE(std::isnan(points.at<cv::Vec3f>(5, 7)[2]));
  EXPECT_TRUE(std::isnan(points.at<cv::Vec3f>(6, 7)[2]));
}

TEST(GeometryTest, CheckDisparityMapRejectsNanAndMinusInf) {
  cv::Mat d(4, 5, CV_32F, cv::Scalar(3.0f));
  d.at<float>(1, 1) = kInvalidDisparity;
  EXPECT_NO_THROW(CheckDisparityMap(d, "d.pfm"));
  d.at<float>(2, 3) = std::numeric_limits<float>::quiet_NaN();
  try {
    CheckDisparityMap(d, "d.pfm");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("d.pfm: pixel (3, 2)"), std::string::npos) << e.what();
  }
  d.at<float>(2, 3) = -std::numeric_limits<float>::infinity();
  EXPECT_THROW(CheckDisparityMap(d, "d.pfm"), InputError);
  EXPECT_THROW(CheckDisparityMap(cv::Mat(), "d.pfm"), InputError);
  EXPECT_THROW(CheckDisparityMap(cv::Mat(3, 3, CV_8U), "d.pfm"), InputError);
}

TEST(GeometryTest, DepthPng16RoundTripInMillimetres) {
  cv::Mat depth(3, 4, CV_32F, cv::Scalar(1.2344f));
  depth.at<float>(0, 0) = kNoDepth;
  depth.at<float>(0, 1) = 70.0f;    // beyond 65.535 m: not representable -> no depth
  depth.at<float>(0, 2) = 0.0004f;  // rounds to 0 mm -> no depth
  depth.at<float>(0, 3) = 6.0f;
  const auto path = std::filesystem::temp_directory_path() / "linesight_depth_test.png";
  WriteDepthPng16(path, depth);
  const cv::Mat back = ReadDepthPng16(path);
  std::filesystem::remove(path);
  EXPECT_EQ(back.at<float>(0, 0), 0.0f);
  EXPECT_EQ(back.at<float>(0, 1), 0.0f);
  EXPECT_EQ(back.at<float>(0, 2), 0.0f);
  EXPECT_NEAR(back.at<float>(0, 3), 6.0f, 1e-6);
  EXPECT_NEAR(back.at<float>(2, 2), 1.234f, 1e-6);
}

}  // namespace
}  // namespace linesight
