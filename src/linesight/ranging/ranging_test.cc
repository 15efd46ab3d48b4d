#include "linesight/ranging/ranging.h"

#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

#include "linesight/core/disparity.h"
#include "linesight/core/error.h"
#include "linesight/ranging/ranging_test_util.h"

namespace linesight {
namespace {

using testing::SphereScene;
using testing::TestGeometry;

TEST(RangingOptionsTest, DefaultsAreValid) { EXPECT_NO_THROW(RangingOptions{}.Check()); }

TEST(RangingOptionsTest, Boundaries) {
  EXPECT_THROW((RangingOptions{.min_depth_m = 0.0}.Check()), OptionError);
  EXPECT_THROW((RangingOptions{.min_depth_m = 2.0, .max_depth_m = 1.0}.Check()), OptionError);
  EXPECT_THROW((RangingOptions{.min_valid_pixels = 0}.Check()), OptionError);
  EXPECT_THROW((RangingOptions{.mode_min_support = 0.0}.Check()), OptionError);
  EXPECT_THROW((RangingOptions{.near_percentile = 0.4}.Check()), OptionError);
  EXPECT_NO_THROW((RangingOptions{.near_percentile = 1.0}.Check()));
  EXPECT_THROW((RangingOptions{.smoothing_radius_px = -1}.Check()), OptionError);
  EXPECT_THROW((RangingOptions{.correlation_length_px = 0.5}.Check()), OptionError);
  EXPECT_THROW((RangingOptions{.core_fraction = 0.0}.Check()), OptionError);
  EXPECT_THROW((RangingOptions{.core_fraction = 1.01}.Check()), OptionError);
  EXPECT_NO_THROW((RangingOptions{.core_fraction = 1.0}.Check()));
  EXPECT_THROW((RangingOptions{.silhouette_margin_x_px = -1}.Check()), OptionError);
  EXPECT_THROW((RangingOptions{.silhouette_margin_y_px = 16}.Check()), OptionError);
  EXPECT_NO_THROW(
      (RangingOptions{.silhouette_margin_x_px = 0, .silhouette_margin_y_px = 0}.Check()));
  EXPECT_THROW((RangingOptions{.surface_band_relative = 0.0}.Check()), OptionError);
  EXPECT_THROW((RangingOptions{.surface_band_relative = 0.25}.Check()), OptionError);
}

TEST(DisparityRangeTest, CoversTheWorkingRange) {
  // f B = 736 * 0.119 = 87.584 px m: 6 m -> 14.6 px, 0.3 m -> 291.9 px.
  const DisparityRange range = DisparityRangeForDepths(TestGeometry(), 0.3, 6.0, 2);
  EXPECT_EQ(range.min_disparity, 12);
  EXPECT_EQ(range.max_disparity(), 294);
  EXPECT_EQ(range.num_disparities, 283);
  const DisparityRange exact = DisparityRangeForDepths(TestGeometry(), 1.0, 2.0, 0);
  EXPECT_EQ(exact.min_disparity, 43);
  EXPECT_EQ(exact.max_disparity(), 88);
  EXPECT_THROW(DisparityRangeForDepths(TestGeometry(), 0.0, 6.0), InputError);
  EXPECT_THROW(DisparityRangeForDepths(TestGeometry(), 3.0, 2.0), InputError);
}

TEST(ParseRoiTest, ParsesAndRejects) {
  EXPECT_EQ(ParseRoi("10,20,30,40"), cv::Rect(10, 20, 30, 40));
  EXPECT_THROW(ParseRoi("10,20,30"), UsageError);
  EXPECT_THROW(ParseRoi("10,20,30,40,5"), UsageError);
  EXPECT_THROW(ParseRoi("a,b,c,d"), UsageError);
}

TEST(GrowRoiTest, GrowsByFractionAndMarginAndClips) {
  // 100x40 box: +15 + 6 = 21 px left/right, +6 + 6 = 12 px top/bottom.
  EXPECT_EQ(GrowRoi(cv::Rect(200, 100, 100, 40), cv::Size(752, 480)), cv::Rect(179, 88, 142, 64));
  // 20x10 box: 3 + 6 = 9 px left/right, 1 + 6 = 7 px top/bottom, clipped at the image border.
  EXPECT_EQ(GrowRoi(cv::Rect(5, 470, 20, 10), cv::Size(752, 480)), cv::Rect(0, 463, 34, 17));
  EXPECT_EQ(GrowRoi(cv::Rect(10, 10, 10, 10), cv::Size(752, 480), 0.0, 0),
            cv::Rect(10, 10, 10, 10));
}

TEST(GrowRoiTest, GrowsByPixelsPerAxisAndClips) {
  EXPECT_EQ(GrowRoiByPixels(cv::Rect(200, 100, 100, 40), 6, 3, cv::Size(752, 480)),
            cv::Rect(194, 97, 112, 46));
  // Clipped on every side that leaves the image; a box outside it grows into an empty ROI.
  EXPECT_EQ(GrowRoiByPixels(cv::Rect(2, 1, 748, 478), 4, 4, cv::Size(752, 480)),
            cv::Rect(0, 0, 752, 480));
  EXPECT_TRUE(GrowRoiByPixels(cv::Rect(900, 10, 10, 10), 4, 4, cv::Size(752, 480)).empty());
}

TEST(SummariseRangeRunsTest, MeanSpreadCoverageAndFailures) {
  std::vector<RangeResult> results(4);
  const std::vector<double> truths = {2.0, 2.0, 4.0, 4.0};
  results[0].status = results[1].status = results[2].status = RangeStatus::kOk;
  results[0].distance_m = 2.1, results[0].sigma_m = 0.1;  // within 2 sigma
  results[1].distance_m = 1.7, results[1].sigma_m = 0.1;  // outside
  results[2].distance_m = 4.2, results[2].sigma_m = 0.1;  // at exactly 2 sigma
  results[3].reason = "too few valid disparities";
  const RangeRunStats s = SummariseRangeRuns(results, truths);
  EXPECT_EQ(s.runs, 4);
  EXPECT_EQ(s.measured, 3);
  EXPECT_EQ(s.covered, 1 + 0 + (std::abs(4.2 - 4.0) <= 2.0 * 0.1));
  EXPECT_NEAR(s.mean_m, (2.1 + 1.7 + 4.2) / 3, 1e-12);
  const double m = (2.1 + 1.7 + 4.2) / 3;
  EXPECT_NEAR(
      s.std_m,
      std::sqrt(((2.1 - m) * (2.1 - m) + (1.7 - m) * (1.7 - m) + (4.2 - m) * (4.2 - m)) / 2),
      1e-12);
  EXPECT_NEAR(s.mean_sigma_m, 0.1, 1e-12);
  EXPECT_NEAR(s.mean_abs_relative, (0.05 + 0.15 + 0.05) / 3, 1e-12);
  ASSERT_EQ(s.failures.size(), 1u);
  EXPECT_EQ(s.failures.at("too few valid disparities"), 1);
  // No measurement at all: zeros, the failures counted.
  const RangeRunStats none = SummariseRangeRuns({results[3]}, {1.0});
  EXPECT_EQ(none.measured, 0);
  EXPECT_EQ(none.mean_m, 0.0);
}

TEST(RangingTest, RejectsBadRoiAndBadDisparity) {
  cv::Mat d(240, 320, CV_32F, cv::Scalar(30.0f));
  try {
    RangeObstacle(d, TestGeometry(), {300, 10, 40, 40}, {});
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("ROI 300,10,40,40 is not inside the 320x240 image"),
              std::string::npos)
        << e.what();
  }
  EXPECT_THROW(RangeObstacle(d, TestGeometry(), {10, 10, 0, 40}, {}), InputError);
  EXPECT_THROW(RangeObstacle(d, TestGeometry(), {-1, 10, 5, 5}, {}), InputError);
  d.at<float>(50, 50) = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(RangeObstacle(d, TestGeometry(), {10, 10, 40, 40}, {}), InputError);
}

TEST(RangingTest, NoMeasurementWithoutValidDisparity) {
  cv::Mat d(240, 320, CV_32F, cv::Scalar(kInvalidDisparity));
  const RangeResult r = RangeObstacle(d, TestGeometry(), {10, 10, 40, 40}, {});
  EXPECT_FALSE(r.ok());
  EXPECT_NE(r.reason.find("no valid disparity"), std::string::npos) << r.reason;
  EXPECT_EQ(r.valid_fraction, 0.0);
  EXPECT_TRUE(RangeResultToJson(r)["distance_m"].is_null());
  // Everything beyond the working range counts as invalid too.
  d.setTo(2.0f);  // 43.8 m
  EXPECT_FALSE(RangeObstacle(d, TestGeometry(), {10, 10, 40, 40}, {}).ok());
}

TEST(RangingTest, NoisefreeFlatTargetIsExact) {
  const StereoGeometry g = TestGeometry();
  cv::Mat d(240, 320, CV_32F, cv::Scalar(float(g.DisparityFromDepth(20.0))));
  d(cv::Rect(100, 80, 60, 50)).setTo(float(g.DisparityFromDepth(2.5)));
  d(cv::Rect(100, 130, 60, 40))
      .setTo(float(g.DisparityFromDepth(3.5)));  // background inside the ROI
  const RangeResult r = RangeObstacle(d, g, {90, 70, 80, 100}, {});
  ASSERT_TRUE(r.ok()) << r.reason;
  EXPECT_NEAR(r.distance_m, 2.5, 1e-5);
  EXPECT_EQ(r.box, cv::Rect(100, 80, 60, 50));
  EXPECT_GE(r.obstacle_pixels,
            60 * 50 - 20);  // the opening against thin structures rounds the corners
  EXPECT_NEAR(r.valid_fraction, 60.0 * 90 / (80 * 100),
              1e-12);  // obstacle and background are valid
  // Noise-free: sigma is the floor only.
  EXPECT_NEAR(r.sigma_m, g.DepthSigma(2.5, RangingOptions{}.disparity_sigma_floor_px), 1e-9);
  // The nearest surface is the target's interior (the silhouette margin left out), at its
  // disparity; the background at 3.5 m inside the ROI is not part of it.
  EXPECT_NEAR(r.surface_disparity_px, g.DisparityFromDepth(2.5), 1e-4);
  EXPECT_EQ(r.matched_disparity_px, r.disparity_px);
  EXPECT_FALSE(r.refined);
  ASSERT_GT(r.surface_pixels.size(), 1000u);
  const cv::Rect interior(100 + 4, 80 + 3, 60 - 8, 50 - 6);
  for (const cv::Point& p : r.surface_pixels) ASSERT_TRUE(interior.contains(p)) << p;
}

// Sphere in front of a background plane with a conductor crossing the ROI and correlated matching
// noise: mean relative error <= 1 % and the truth within +-2 sigma in >= 90 % of 40 runs, at
// several distances.
TEST(RangingTest, SphereDistanceIsAccurateAndSigmaIsCalibrated) {
  const StereoGeometry g = TestGeometry();
  for (double distance : {0.8, 2.0, 4.0}) {
    const double radius = 0.06;
    double sum_error = 0.0;
    int covered = 0, runs = 40;
    for (int seed = 0; seed < runs; ++seed) {
      cv::Rect box;
      const cv::Mat d =
          SphereScene(g, distance, radius, {170, 110}, distance + 0.8, 0.15, unsigned(seed), &box);
      const cv::Rect roi = (box + cv::Size(30, 30) - cv::Point(15, 15)) & cv::Rect(0, 0, 320, 240);
      const RangeResult r = RangeObstacle(d, g, roi, {});
      ASSERT_TRUE(r.ok()) << r.reason;
      sum_error += (r.distance_m - distance) / distance;
      covered += std::abs(r.distance_m - distance) <= 2.0 * r.sigma_m;
      if (std::getenv("LS_DEBUG"))
        std::printf("%.2f: %.4f +- %.4f n %d box %d %d %d %d roi %d %d %d %d\n", distance,
                    r.distance_m, r.sigma_m, r.obstacle_pixels, r.box.x, r.box.y, r.box.width,
                    r.box.height, roi.x, roi.y, roi.width, roi.height);
    }
    EXPECT_LT(std::abs(sum_error / runs), 0.01) << "at " << distance << " m";
    EXPECT_GE(covered, int(0.85 * runs)) << "at " << distance << " m";
  }
}

// An occluder in front that overlaps only the ROI's margin (the damper at 1.5 m before the clamp
// at 3 m) must not be taken for the obstacle; one that covers the ROI's core is the obstacle.
TEST(RangingTest, OccluderInTheMarginIsIgnoredUnlessItCoversTheCore) {
  const StereoGeometry g = TestGeometry();
  cv::Mat d(240, 320, CV_32F, cv::Scalar(float(g.DisparityFromDepth(20.0))));
  const cv::Rect roi(100, 60, 100, 100);
  d(cv::Rect(120, 80, 60, 60)).setTo(float(g.DisparityFromDepth(3.0)));  // the obstacle
  d(cv::Rect(60, 40, 60, 140)).setTo(float(g.DisparityFromDepth(1.5)));  // occluder, left margin
  RangeResult r = RangeObstacle(d, g, roi, {});
  ASSERT_TRUE(r.ok()) << r.reason;
  EXPECT_NEAR(r.distance_m, 3.0, 1e-5);
  EXPECT_EQ(r.box, cv::Rect(120, 80, 60, 60));
  // Counting support over the whole ROI takes the occluder (20 % of the ROI), as before.
  r = RangeObstacle(d, g, roi, {.core_fraction = 1.0});
  ASSERT_TRUE(r.ok()) << r.reason;
  EXPECT_NEAR(r.distance_m, 1.5, 1e-5);
  // Occluder reaching well into the core: it is what the ROI shows nearest.
  d(cv::Rect(60, 40, 90, 140)).setTo(float(g.DisparityFromDepth(1.5)));
  r = RangeObstacle(d, g, roi, {});
  ASSERT_TRUE(r.ok()) << r.reason;
  EXPECT_NEAR(r.distance_m, 1.5, 1e-5);
}

// A pixel piece of the obstacle's depth in the ROI's margin that does not reach the core belongs to
// something else: it is not part of the obstacle's box.
TEST(RangingTest, PiecesOutsideTheCoreAreDropped) {
  const StereoGeometry g = TestGeometry();
  cv::Mat d(240, 320, CV_32F, cv::Scalar(float(g.DisparityFromDepth(20.0))));
  d(cv::Rect(130, 90, 40, 40)).setTo(float(g.DisparityFromDepth(2.0)));
  d(cv::Rect(100, 60, 19, 19)).setTo(float(g.DisparityFromDepth(1.98)));  // corner piece
  // (Thin-structure removal off, so that only the connected-piece rule can drop the corner.)
  const RangeResult r = RangeObstacle(d, g, {100, 60, 100, 100}, {.min_body_width_m = 0.0});
  ASSERT_TRUE(r.ok()) << r.reason;
  EXPECT_NEAR(r.distance_m, 2.0, 1e-5);
  EXPECT_EQ(r.box, cv::Rect(130, 90, 40, 40));
}

// A 20 m background with an obstacle at 3 m (`inner`) inside a rim (`outer` minus `inner`) whose
// disparity is 2 % too large, as a matcher's edge fattening leaves it.
cv::Mat ObstacleWithFattenedRim(const StereoGeometry& g, const cv::Rect& outer,
                                const cv::Rect& inner) {
  cv::Mat d(240, 320, CV_32F, cv::Scalar(float(g.DisparityFromDepth(20.0))));
  const float true_d = float(g.DisparityFromDepth(3.0));
  d(outer).setTo(1.02f * true_d);
  d(inner).setTo(true_d);
  return d;
}

// Edge fattening: a 3 px rim around the obstacle carries a disparity 2 % too large (the nearer side
// of a depth edge spread by the matcher's window). Leaving the silhouette out of the percentile
// removes the bias; with the margin disabled the rim pulls the distance ~2 % nearer, and sigma
// reports the shift.
TEST(RangingTest, SilhouetteMarginRemovesEdgeFattening) {
  const StereoGeometry g = TestGeometry();
  const float true_d = float(g.DisparityFromDepth(3.0));
  const cv::Mat d = ObstacleWithFattenedRim(g, {117, 87, 66, 56}, {120, 90, 60, 50});
  const cv::Rect roi(100, 70, 100, 90);
  const RangeResult with_margin = RangeObstacle(d, g, roi, {});
  ASSERT_TRUE(with_margin.ok()) << with_margin.reason;
  EXPECT_NEAR(with_margin.distance_m, 3.0, 1e-5);
  const RangeResult without =
      RangeObstacle(d, g, roi, {.silhouette_margin_x_px = 0, .silhouette_margin_y_px = 0});
  ASSERT_TRUE(without.ok()) << without.reason;
  EXPECT_LT(without.distance_m, 3.0 * 0.99);
  // Sigma covers half the shift between the two pixel sets.
  EXPECT_GT(with_margin.disparity_sigma_px, 0.5 * 0.02 * true_d * 0.9);
}

// On a small obstacle the full margin leaves fewer than min_valid_pixels (here a 12x10 blob: 4x4
// after the 9x7 erosion); the margin then shrinks until enough remain instead of being dropped, so
// a 1 px fattened rim is still left out (it would pull the distance ~2 % nearer).
TEST(RangingTest, SilhouetteMarginShrinksOnSmallObstacles) {
  const StereoGeometry g = TestGeometry();
  const cv::Mat d = ObstacleWithFattenedRim(g, {118, 88, 12, 10}, {119, 89, 10, 8});
  const cv::Rect roi(110, 80, 28, 26);
  const RangeResult r = RangeObstacle(d, g, roi, {.min_body_width_m = 0.0});
  ASSERT_TRUE(r.ok()) << r.reason;
  EXPECT_EQ(r.obstacle_pixels, 120);
  EXPECT_NEAR(r.distance_m, 3.0, 1e-5);
}

// A thin near band on top of an obstacle, as an insulator's rim above its shed: 8 rows at the
// nearest disparity, then the surface recedes 10 % over 20 rows and stays there. Pixels where
// (x + 2y) % 5 == 0 in rows [holes_y0, holes_y1) are rejected (no disparity), as a matcher's
// checks reject scattered pixels of a weakly textured rim.
cv::Mat RimOverRamp(const StereoGeometry& g, int holes_y0, int holes_y1) {
  cv::Mat d(240, 320, CV_32F, cv::Scalar(float(g.DisparityFromDepth(20.0))));
  const double front = g.DisparityFromDepth(3.0);
  for (int y = 90; y < 140; ++y) {
    const double recede = y < 98 ? 0.0 : 0.1 * std::min(1.0, (y - 97) / 20.0);
    d.row(y).colRange(120, 180).setTo(float(front * (1.0 - recede)));
    for (int x = 120; x < 180 && y >= holes_y0 && y < holes_y1; ++x) {
      if ((x + 2 * y) % 5 == 0) d.at<float>(y, x) = kInvalidDisparity;
    }
  }
  return d;
}

// Every rejected pixel would cut a 9x7 margin out of the rim and remove it from the percentile
// (the distance then reads 2 % too far); the enclosed holes are filled, so the rim is kept.
TEST(RangingTest, RejectedPixelsOnAThinFrontDoNotRemoveIt) {
  const StereoGeometry g = TestGeometry();
  const cv::Mat d = RimOverRamp(g, 90, 98);
  const cv::Rect roi(100, 70, 100, 90);
  const RangeResult filled = RangeObstacle(d, g, roi, {});
  ASSERT_TRUE(filled.ok()) << filled.reason;
  EXPECT_NEAR(filled.distance_m, 3.0, 1e-4);
  const RangeResult unfilled = RangeObstacle(d, g, roi, {.fill_rejected_holes = false});
  ASSERT_TRUE(unfilled.ok()) << unfilled.reason;
  EXPECT_GT(unfilled.distance_m, 3.0 * 1.015);
}

// Holes that cost no surface (here on the receding part) leave the result exactly as without
// filling: the filled interior is only taken when it shows a surface beyond the band.
TEST(RangingTest, RejectedPixelsAwayFromTheFrontChangeNothing) {
  const StereoGeometry g = TestGeometry();
  const cv::Mat d = RimOverRamp(g, 110, 120);
  const cv::Rect roi(100, 70, 100, 90);
  const RangeResult filled = RangeObstacle(d, g, roi, {});
  const RangeResult unfilled = RangeObstacle(d, g, roi, {.fill_rejected_holes = false});
  ASSERT_TRUE(filled.ok()) << filled.reason;
  ASSERT_TRUE(unfilled.ok()) << unfilled.reason;
  EXPECT_NEAR(filled.distance_m, 3.0, 1e-4);
  EXPECT_EQ(filled.distance_m, unfilled.distance_m);
  EXPECT_EQ(filled.disparity_sigma_px, unfilled.disparity_sigma_px);
  EXPECT_EQ(filled.surface_pixels, unfilled.surface_pixels);
}

// A clamp seen from 4 m is thin all over (5-6 px frame bars and saddle, below the 9 px body width)
// and the conductor running into it is nearer (a piece at 2.9 m crossing the ROI's core). With no
// body left, the nearest mode is the conductor piece; the mode with the most support is the clamp.
TEST(RangingTest, WithoutBodiesTheLargestModeIsTheObstacle) {
  const StereoGeometry g = TestGeometry();
  cv::Mat d(240, 320, CV_32F, cv::Scalar(float(g.DisparityFromDepth(20.0))));
  const float clamp = float(g.DisparityFromDepth(4.0));
  d(cv::Rect(128, 88, 45, 6)).setTo(clamp);  // top bar
  d(cv::Rect(128, 88, 5, 45)).setTo(clamp);  // side bars
  d(cv::Rect(168, 88, 5, 45)).setTo(clamp);
  d(cv::Rect(128, 127, 45, 6)).setTo(clamp);  // saddle
  for (int y = 70; y < 126; ++y) {            // conductor piece, 6 px wide
    const int x = 112 + int(std::lround(0.7 * (y - 70)));
    d.row(y).colRange(x - 3, x + 3).setTo(float(g.DisparityFromDepth(2.9)));
  }
  const cv::Rect roi(110, 70, 80, 80);
  const RangeResult largest = RangeObstacle(d, g, roi, {});
  ASSERT_TRUE(largest.ok()) << largest.reason;
  EXPECT_NEAR(largest.distance_m, 4.0, 1e-4);
  const RangeResult nearest = RangeObstacle(d, g, roi, {.largest_mode_without_bodies = false});
  ASSERT_TRUE(nearest.ok()) << nearest.reason;
  EXPECT_NEAR(nearest.distance_m, 2.9, 1e-3);
}

}  // namespace
}  // namespace linesight
