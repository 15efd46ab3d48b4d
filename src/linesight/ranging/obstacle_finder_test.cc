#include "linesight/ranging/obstacle_finder.h"

#include <gtest/gtest.h>

#include "linesight/core/error.h"
#include "linesight/ranging/ranging_test_util.h"

namespace linesight {
namespace {

using testing::TestGeometry;

TEST(ObstacleFinderOptionsTest, DefaultsAreValidAndBoundsAreChecked) {
  EXPECT_NO_THROW(ObstacleFinderOptions{}.Check());
  EXPECT_THROW((ObstacleFinderOptions{.min_width_m = 0.0}.Check()), OptionError);
  EXPECT_THROW((ObstacleFinderOptions{.min_depth_m = 3.0, .max_depth_m = 2.0}.Check()),
               OptionError);
  EXPECT_THROW((ObstacleFinderOptions{.min_area_px = 0}.Check()), OptionError);
}

// Two blocks on a conductor ramp, far background: both blocks are found, the conductor is not, and
// the results come sorted by distance.
TEST(ObstacleFinderTest, FindsBlocksButNotTheConductor) {
  const StereoGeometry g = TestGeometry();
  cv::Mat d(240, 320, CV_32F, cv::Scalar(kInvalidDisparity));  // sky
  d.rowRange(200, 240).setTo(
      float(g.DisparityFromDepth(30.0)));  // terrain beyond the working range
  // Conductor: 5 px thick, from 1 m (bottom left) to 6 m (towards the centre).
  for (int x = 0; x < 300; ++x) {
    const double z = 1.0 + 5.0 * x / 300.0;
    for (int t = 0; t < 5; ++t) d.at<float>(180 - x / 3 + t, x) = float(g.DisparityFromDepth(z));
  }
  // Block A at 3 m: 10 cm square -> 24 px. Block B at 1.5 m: 8 cm -> 39 px.
  d(cv::Rect(150, 110, 25, 25)).setTo(float(g.DisparityFromDepth(3.0)));
  d(cv::Rect(60, 130, 39, 39)).setTo(float(g.DisparityFromDepth(1.5)));
  d += testing::CorrelatedNoise(d.size(), 0.1, 5);
  const std::vector<RangeResult> results = RangeAllObstacles(d, g, {}, {});
  ASSERT_EQ(results.size(), 2u);
  EXPECT_NEAR(results[0].distance_m, 1.5, 0.015);
  EXPECT_NEAR(results[1].distance_m, 3.0, 0.03);
  EXPECT_LE(std::abs(results[0].box.x - 60), 2);
  EXPECT_LE(std::abs(results[1].box.y - 110), 2);
}

// A small block at 3 m in front of a tall one at 4.5 m whose box contains it (the clamp before the
// insulator string in `linesight demo`): two obstacles, not one merged region; two overlapping
// parts at nearly one depth (a damper's weights) still merge.
TEST(ObstacleFinderTest, OverlappingRegionsAtDifferentDepthsStaySeparate) {
  const StereoGeometry g = TestGeometry();
  cv::Mat d(240, 320, CV_32F, cv::Scalar(kInvalidDisparity));
  d(cv::Rect(140, 20, 40, 200)).setTo(float(g.DisparityFromDepth(4.5)));
  d(cv::Rect(150, 150, 20, 20)).setTo(float(g.DisparityFromDepth(3.0)));
  d += testing::CorrelatedNoise(d.size(), 0.05, 5);
  const std::vector<RangeResult> results = RangeAllObstacles(d, g, {}, {});
  ASSERT_EQ(results.size(), 2u);
  EXPECT_NEAR(results[0].distance_m, 3.0, 0.03);
  EXPECT_NEAR(results[1].distance_m, 4.5, 0.05);
  // The old rule (overlap only) merges them.
  ObstacleFinderOptions overlap_only;
  overlap_only.merge_depth_log_ratio = 10.0;
  EXPECT_EQ(FindObstacleRegions(d, g, overlap_only).size(), 1u);

  cv::Mat parts(240, 320, CV_32F, cv::Scalar(kInvalidDisparity));
  parts(cv::Rect(100, 100, 40, 40)).setTo(float(g.DisparityFromDepth(1.5)));
  parts(cv::Rect(104, 96, 40, 40)).setTo(float(g.DisparityFromDepth(1.7)));
  EXPECT_EQ(FindObstacleRegions(parts, g, {}).size(), 1u);
}

TEST(ObstacleFinderTest, NothingInRangeFindsNothing) {
  const StereoGeometry g = TestGeometry();
  cv::Mat d(240, 320, CV_32F, cv::Scalar(float(g.DisparityFromDepth(40.0))));
  EXPECT_TRUE(FindObstacleRegions(d, g, {}).empty());
}

}  // namespace
}  // namespace linesight
