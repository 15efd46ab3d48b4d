#include "linesight/ranging/thin_structures.h"

#include <gtest/gtest.h>

#include "linesight/core/error.h"
#include "linesight/ranging/ranging_test_util.h"

namespace linesight {
namespace {

TEST(ThinStructureOptionsTest, DefaultsAreValidAndBoundsAreChecked) {
  EXPECT_NO_THROW(ThinStructureOptions{}.Check());
  EXPECT_THROW((ThinStructureOptions{.min_width_m = 0.0}.Check()), OptionError);
  EXPECT_THROW((ThinStructureOptions{.depth_band_relative = 0.0}.Check()), OptionError);
  EXPECT_THROW((ThinStructureOptions{.min_depth_m = 2.0, .max_depth_m = 1.0}.Check()), OptionError);
}

// A 27 mm conductor at 2 m (10 px) is thin; a 10 cm block at 2 m (37 px) is a body, holes and all.
TEST(BodyMaskTest, DropsTheConductorAndKeepsTheBlock) {
  const StereoGeometry g = testing::TestGeometry();
  const float d = float(g.DisparityFromDepth(2.0));
  cv::Mat disparity(240, 320, CV_32F, cv::Scalar(kInvalidDisparity));
  disparity(cv::Rect(0, 100, 320, 10)).setTo(d);     // conductor, 10 px high
  disparity(cv::Rect(150, 60, 37, 37)).setTo(d);     // block above it
  disparity.at<float>(75, 165) = kInvalidDisparity;  // a matching hole inside the block
  const cv::Rect region(100, 40, 150, 90);
  const cv::Mat body = BodyMask(disparity, g, region, {});
  ASSERT_EQ(body.size(), region.size());
  EXPECT_EQ(body.at<uchar>(105 - 40, 20), 0);          // conductor, away from the block
  EXPECT_EQ(body.at<uchar>(78 - 40, 168 - 100), 255);  // block centre
  EXPECT_EQ(body.at<uchar>(62 - 40, 168 - 100), 255);  // near the block's top edge (grown back)
  EXPECT_GT(cv::countNonZero(body), 37 * 37 * 8 / 10);
  // Conductor pixels right under the block (same depth, within the body radius of 8 px) are kept
  // with it.
  EXPECT_LT(cv::countNonZero(body), 37 * 37 + 37 * 16);
}

}  // namespace
}  // namespace linesight
