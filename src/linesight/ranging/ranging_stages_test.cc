#include "linesight/ranging/ranging_stages.h"

#include <gtest/gtest.h>

#include "linesight/core/disparity.h"
#include "linesight/ranging/ranging_test_util.h"

namespace linesight::detail {
namespace {

using testing::CorrelatedNoise;
using testing::TestGeometry;

// Disparity of depth z for TestGeometry (doffs 0).
float DisparityAt(double z) {
  return float(TestGeometry().focal_px * TestGeometry().baseline_m / z);
}

// A 60x40 ROI: a far wall at `far_m`, and a rectangle `near_box` at `near_m`.
cv::Mat TwoPlanes(double far_m, double near_m, cv::Rect near_box) {
  cv::Mat view(40, 60, CV_32F, cv::Scalar(DisparityAt(far_m)));
  view(near_box).setTo(DisparityAt(near_m));
  return view;
}

RangingOptions NoBodyFilter() {
  RangingOptions o;
  o.min_body_width_m = 0.0;
  return o;
}

TEST(SelectWorkingPixels, KeepsFiniteDisparitiesOfTheWorkingDepthsInRowOrder) {
  RangingOptions o;
  o.min_depth_m = 1.0;
  o.max_depth_m = 4.0;
  cv::Mat view = (cv::Mat_<float>(2, 3) << DisparityAt(2.0), kInvalidDisparity, DisparityAt(8.0),
                  DisparityAt(0.5), DisparityAt(3.0), DisparityAt(1.0));
  const WorkingPixels w = SelectWorkingPixels(view, TestGeometry(), o);
  const cv::Mat expected = (cv::Mat_<uchar>(2, 3) << 1, 0, 0, 0, 1, 1);
  EXPECT_EQ(cv::countNonZero(w.valid != expected), 0);
  EXPECT_EQ(w.values, (std::vector<float>{DisparityAt(2.0), DisparityAt(3.0), DisparityAt(1.0)}));
  EXPECT_DOUBLE_EQ(w.d_low, TestGeometry().DisparityFromDepth(4.0));
  EXPECT_DOUBLE_EQ(w.d_high, TestGeometry().DisparityFromDepth(1.0));
}

TEST(KeepBodies, WithTheFilterOffEveryPixelStays) {
  const cv::Mat view = TwoPlanes(5.0, 2.0, {20, 10, 20, 20});
  WorkingPixels w = SelectWorkingPixels(view, TestGeometry(), NoBodyFilter());
  const size_t before = w.values.size();
  EXPECT_TRUE(KeepBodies(view, TestGeometry(), {0, 0, 60, 40}, NoBodyFilter(), &w));
  EXPECT_EQ(w.values.size(), before);
}

TEST(KeepBodies, AThinBarAloneIsKeptAndReportedAsThin) {
  // Only a 2 px wide bar at 2 m (4.4 mm wide there) is in range: no body remains.
  cv::Mat view(40, 60, CV_32F, cv::Scalar(kInvalidDisparity));
  view.colRange(30, 32).setTo(DisparityAt(2.0));
  RangingOptions o;
  WorkingPixels w = SelectWorkingPixels(view, TestGeometry(), o);
  EXPECT_FALSE(KeepBodies(view, TestGeometry(), {0, 0, 60, 40}, o, &w));
  EXPECT_EQ(w.values.size(), 80u);
}

TEST(FindObstacleMode, TakesTheNearestModeWithEnoughSupport) {
  const cv::Mat view = TwoPlanes(5.0, 2.0, {22, 12, 16, 16});
  const WorkingPixels w = SelectWorkingPixels(view, TestGeometry(), NoBodyFilter());
  const DepthMode mode = FindObstacleMode(view, w, 0.0, false, NoBodyFilter());
  ASSERT_TRUE(mode.found);
  EXPECT_TRUE(mode.use_core);
  const int near_bin = mode.bins.Bin(DisparityAt(2.0));
  EXPECT_GE(near_bin, mode.first);
  EXPECT_LE(near_bin, mode.last);
  EXPECT_LT(mode.bins.Bin(DisparityAt(5.0)), mode.first);
}

TEST(FindObstacleMode, TooLittleSupportGivesTheModeBehind) {
  const cv::Mat view = TwoPlanes(5.0, 2.0, {28, 18, 3, 3});  // 9 of the core's 864 pixels
  const WorkingPixels w = SelectWorkingPixels(view, TestGeometry(), NoBodyFilter());
  const DepthMode mode = FindObstacleMode(view, w, 0.0, false, NoBodyFilter());
  ASSERT_TRUE(mode.found);
  const int far_bin = mode.bins.Bin(DisparityAt(5.0));
  EXPECT_GE(far_bin, mode.first);
  EXPECT_LE(far_bin, mode.last);
}

TEST(FindObstacleMode, WithoutBodiesTheLargestModeWins) {
  // The nearer plane holds 30 % of the core: the nearest mode by the usual rule, but with only
  // thin structures left the mode with the most support is the obstacle.
  const cv::Mat view = TwoPlanes(5.0, 2.0, {22, 12, 16, 16});
  const WorkingPixels w = SelectWorkingPixels(view, TestGeometry(), NoBodyFilter());
  RangingOptions o = NoBodyFilter();
  auto holds = [](const DepthMode& mode, float d) {
    return mode.found && mode.bins.Bin(d) >= mode.first && mode.bins.Bin(d) <= mode.last;
  };
  EXPECT_TRUE(holds(FindObstacleMode(view, w, 0.0, false, o), DisparityAt(2.0)));
  const DepthMode largest = FindObstacleMode(view, w, 0.0, true, o);
  EXPECT_TRUE(holds(largest, DisparityAt(5.0)));
  EXPECT_FALSE(holds(largest, DisparityAt(2.0)));
  o.largest_mode_without_bodies = false;
  EXPECT_TRUE(holds(FindObstacleMode(view, w, 0.0, true, o), DisparityAt(2.0)));
}

TEST(ObstacleMask, PiecesAtTheObstaclesDepthOutsideTheCoreAreDropped) {
  cv::Mat view = TwoPlanes(5.0, 2.0, {22, 12, 16, 16});
  view(cv::Rect(0, 0, 4, 4)).setTo(DisparityAt(2.0));  // same depth, in the ROI's corner
  const WorkingPixels w = SelectWorkingPixels(view, TestGeometry(), NoBodyFilter());
  const DepthMode mode = FindObstacleMode(view, w, 0.0, false, NoBodyFilter());
  const cv::Mat obstacle = ObstacleMask(view, w, mode);
  EXPECT_EQ(cv::countNonZero(obstacle), 16 * 16);
  EXPECT_EQ(cv::boundingRect(obstacle), cv::Rect(22, 12, 16, 16));
}

TEST(SmoothObstacle, RadiusZeroKeepsTheRawValuesAndAFlatSurfaceHasNoResiduals) {
  const cv::Mat view = TwoPlanes(5.0, 2.0, {22, 12, 16, 16});
  cv::Mat obstacle(view.size(), CV_8U, cv::Scalar(0));
  obstacle(cv::Rect(22, 12, 16, 16)).setTo(1);
  const SmoothedObstacle s = SmoothObstacle(view, obstacle, 0);
  ASSERT_EQ(s.points.size(), 256u);
  EXPECT_EQ(s.points.front(), cv::Point(22, 12));
  EXPECT_EQ(s.smoothed, s.raw);
  for (float r : s.residuals) EXPECT_EQ(r, 0.0f);
}

TEST(SmoothObstacle, OnlyTheObstaclesPixelsVote) {
  // A 3x3 median at the obstacle's corner sees 4 obstacle pixels and 5 of the wall: the wall's
  // values must not enter.
  const cv::Mat view = TwoPlanes(5.0, 2.0, {22, 12, 16, 16});
  cv::Mat obstacle(view.size(), CV_8U, cv::Scalar(0));
  obstacle(cv::Rect(22, 12, 16, 16)).setTo(1);
  const SmoothedObstacle s = SmoothObstacle(view, obstacle, 1);
  for (float d : s.smoothed) EXPECT_EQ(d, DisparityAt(2.0));
}

TEST(NearestSurface, AFlatFrontReadsItsOwnDisparityFromTheInterior) {
  // A front at 2 m whose outer 2 px read nearer (the matcher's edge fattening).
  const cv::Rect front(10, 5, 40, 30);
  cv::Mat view = TwoPlanes(5.0, 1.9, front);
  view(cv::Rect(12, 7, 36, 26)).setTo(DisparityAt(2.0));
  cv::Mat obstacle(view.size(), CV_8U, cv::Scalar(0));
  obstacle(front).setTo(1);
  const RangingOptions o = NoBodyFilter();
  const SmoothedObstacle s = SmoothObstacle(view, obstacle, 0);
  const NearSurface near = NearestSurface(view, obstacle, s, {100, 200}, 0.0, o);
  EXPECT_FLOAT_EQ(float(near.disparity_px), DisparityAt(2.0));
  ASSERT_FALSE(near.points.empty());
  for (const cv::Point& p : near.points) {
    EXPECT_GE(p.x, 100 + front.x + o.silhouette_margin_x_px);
    EXPECT_GE(p.y, 200 + front.y + o.silhouette_margin_y_px);
  }
}

TEST(NearestSurface, RejectedHolesDoNotRemoveAThinRim) {
  // A 9 px tall rim in front (2 m) of a body (2.2 m), with rejected (invalid) pixels scattered
  // over the rim: the margins around the holes would leave no rim pixel in the interior.
  cv::Mat view(40, 60, CV_32F, cv::Scalar(DisparityAt(2.2)));
  view(cv::Rect(5, 14, 50, 9)).setTo(DisparityAt(2.0));
  for (int x = 8; x < 55; x += 6) {
    view.at<float>(15, x) = kInvalidDisparity;
    view.at<float>(21, x) = kInvalidDisparity;
  }
  cv::Mat obstacle = (view > 0) & (view < 1e9);
  obstacle /= 255;
  RangingOptions o = NoBodyFilter();
  const SmoothedObstacle s = SmoothObstacle(view, obstacle, 0);
  const NearSurface filled = NearestSurface(view, obstacle, s, {0, 0}, 0.0, o);
  EXPECT_FLOAT_EQ(float(filled.disparity_px), DisparityAt(2.0));
  o.fill_rejected_holes = false;
  const NearSurface unfilled = NearestSurface(view, obstacle, s, {0, 0}, 0.0, o);
  EXPECT_LT(unfilled.disparity_px, DisparityAt(2.0));
}

TEST(NearSurfaceSigma, GrowsWithTheNoiseAndNeverFallsBelowTheFloor) {
  const RangingOptions o = NoBodyFilter();
  cv::Mat obstacle(40, 60, CV_8U, cv::Scalar(1));
  auto sigma_for = [&](double noise) {
    cv::Mat view(40, 60, CV_32F, cv::Scalar(DisparityAt(2.0)));
    if (noise > 0) view += CorrelatedNoise(view.size(), noise, 7);
    const SmoothedObstacle s = SmoothObstacle(view, obstacle, o.smoothing_radius_px);
    return NearSurfaceSigma(NearestSurface(view, obstacle, s, {0, 0}, 0.0, o), s, o);
  };
  EXPECT_NEAR(sigma_for(0.0), o.disparity_sigma_floor_px, 1e-12);
  const double low = sigma_for(0.1), high = sigma_for(0.4);
  EXPECT_GT(low, o.disparity_sigma_floor_px);
  EXPECT_GT(high, low + 0.02);
}

}  // namespace
}  // namespace linesight::detail
