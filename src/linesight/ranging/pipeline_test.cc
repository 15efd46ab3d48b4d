#include "linesight/ranging/pipeline.h"

#include <cmath>

#include <gtest/gtest.h>

#include "linesight/core/disparity.h"
#include "linesight/core/error.h"
#include "linesight/sim/power_line_scene.h"

namespace linesight {
namespace {

// The chain's settings with isgm on one thread.
RangingPipelineOptions IsgmOnOneThread() {
  RangingPipelineOptions options;
  options.method = "isgm";
  options.threads = 1;
  return options;
}

TEST(RangingPipelineOptionsTest, DefaultsAreValidAndBoundsAreChecked) {
  EXPECT_NO_THROW(RangingPipelineOptions{}.Check());
  RangingPipelineOptions o;
  o.model_relative_sigma = -0.01;
  EXPECT_THROW(o.Check(), OptionError);
  o.model_relative_sigma = 0.5;
  EXPECT_THROW(o.Check(), OptionError);
  o.model_relative_sigma = 0.0;
  EXPECT_NO_THROW(o.Check());
  o.surface_disagreement_weight = -0.5;
  EXPECT_THROW(o.Check(), OptionError);
  o.surface_disagreement_weight = 1.0;
  o.surface.min_pixels = 2;
  EXPECT_THROW(o.Check(), OptionError);
}

// A rendered damper at 2 m ranged through the whole chain (rectify, isgm, ranging) with the true
// calibration: the checked map is isgm's SGM stage (a subset of the dense map: most of the
// textureless sky and terrain is left invalid), and the distance is within 1.5 % with the model
// sigma included.
TEST(RangingPipelineTest, IsgmRunsWithEightPathsUnlessTheCallerSetsThem) {
  using Params = std::map<std::string, std::string>;
  EXPECT_EQ(RangingMatcherParams("isgm", {}), (Params{{"paths", "8"}}));
  EXPECT_EQ(RangingMatcherParams("isgm", {{"paths", "4"}, {"p1", "10"}}),
            (Params{{"paths", "4"}, {"p1", "10"}}));
  EXPECT_EQ(RangingMatcherParams("sgbm", {{"block", "5"}}), (Params{{"block", "5"}}));
  EXPECT_EQ(RangingMatcherParams("", {}), (Params{{"paths", "8"}}));  // the default is isgm
  // The chain's matcher reports the setting it runs with.
  sim::PowerLineSceneOptions scene_options;
  RangingPipelineOptions options;
  const RangingPipeline pipeline(sim::MakeStereoCalibration(scene_options.rig), options);
  EXPECT_EQ(pipeline.matcher().Settings()["sgm"]["paths"], 8);
  options.params = {{"paths", "4"}};
  const RangingPipeline four(sim::MakeStereoCalibration(scene_options.rig), options);
  EXPECT_EQ(four.matcher().Settings()["sgm"]["paths"], 4);
}

TEST(RangingPipelineTest, RangesOnTheCheckedDisparitiesOfIsgm) {
  sim::PowerLineSceneOptions scene_options;
  scene_options.sensor.supersampling = 1;
  scene_options.obstacles = {{sim::ObstacleType::kDamper, 2.0, 0}};
  const sim::PowerLineScene scene = sim::RenderPowerLineScene(scene_options);
  ASSERT_EQ(scene.obstacles.size(), 1u);
  const cv::Rect box = scene.obstacles.front().box;
  const cv::Rect roi = (box + cv::Size(24, 24) - cv::Point(12, 12)) &
                       cv::Rect(0, 0, scene.left.cols, scene.left.rows);
  const RangingPipelineOptions options = IsgmOnOneThread();
  const RangingPipeline pipeline(sim::MakeStereoCalibration(scene_options.rig), options);
  const RangingFrame frame =
      pipeline.Process(scene.left, scene.right, cv::Range(roi.y, roi.br().y));
  ASSERT_EQ(frame.checked_disparity.size(), frame.disparity.size());
  int dense = 0, checked = 0, checked_not_dense = 0;
  for (int y = roi.y; y < roi.br().y; ++y) {
    for (int x = 0; x < frame.disparity.cols; ++x) {
      const bool d = IsValidDisparity(frame.disparity.at<float>(y, x));
      const bool c = IsValidDisparity(frame.checked_disparity.at<float>(y, x));
      dense += d;
      checked += c;
      checked_not_dense += c && !d;
    }
  }
  // (A handful of pixels can differ: the d <= x rule cuts the dense and checked values separately.)
  EXPECT_LE(checked_not_dense, checked / 1000);
  // Searching from disparity 0, the terrain matches at its true disparity and passes the checks;
  // sky, occlusions and unmatched borders are left out.
  EXPECT_LT(checked, dense * 95 / 100);
  EXPECT_GT(checked, dense / 10);
  const RangeResult r = pipeline.RangeRois(frame, {roi}).front();
  ASSERT_TRUE(r.ok()) << r.reason;
  const double truth = scene.obstacles.front().distance_m;
  EXPECT_NEAR(r.distance_m, truth, 0.015 * truth);
  EXPECT_GE(r.sigma_m, options.model_relative_sigma * r.distance_m);
  // By default the front surface is refined on the images: the damper's textured end cap
  // refines (NCC above the gate) and stays within 1.5 %; sigma grows by the refinement's terms.
  EXPECT_TRUE(r.refined);
  EXPECT_EQ(r.refinement, "surface");
  ASSERT_TRUE(std::isfinite(r.surface_check_px));
  auto range_with = [&](const RangingPipelineOptions& changed) {
    const RangingPipeline p(sim::MakeStereoCalibration(scene_options.rig), changed);
    return p.RangeRois(frame, {roi}).front();
  };
  RangingPipelineOptions unchecked = options;
  unchecked.refine_on_images = false;
  const RangeResult r0 = range_with(unchecked);
  ASSERT_TRUE(r0.ok()) << r0.reason;
  EXPECT_FALSE(r0.refined);
  EXPECT_TRUE(r0.refinement.empty());
  EXPECT_FALSE(std::isfinite(r0.surface_check_px));
  EXPECT_EQ(r.matched_disparity_px, r0.disparity_px);
  EXPECT_NEAR(r.disparity_px - r0.disparity_px, r.surface_check_px, 1e-9);
  const double w = options.surface_disagreement_weight;
  EXPECT_GE(r.disparity_sigma_px + 1e-12,
            std::hypot(r0.disparity_sigma_px, w * r.surface_check_px));
  EXPECT_GE(r.sigma_m, r0.sigma_m);
  // A check only: the matched distance, the disagreement in sigma.
  auto expect_check_only = [&](const RangeResult& c) {
    ASSERT_TRUE(c.ok()) << c.reason;
    EXPECT_FALSE(c.refined);
    EXPECT_EQ(c.distance_m, r0.distance_m);
    ASSERT_TRUE(std::isfinite(c.surface_check_px));
    EXPECT_NEAR(c.disparity_sigma_px, std::hypot(r0.disparity_sigma_px, w * c.surface_check_px),
                1e-12);
    EXPECT_GE(c.sigma_m, r0.sigma_m);
  };

  // Too few clean pixels to correct (a gradient selection that keeps almost none): the fit on
  // all the surface's pixels is a check.
  RangingPipelineOptions strict = options;
  strict.surface.gradient_ratio = 1e-3;
  strict.edges.min_rows = 1000000;  // and no edges
  expect_check_only(range_with(strict));
}

// Every obstacle type at 0.3 m, the near end of the working range, in the default scene (the
// rig turned towards the line, which crosses in front of it): rendered, rectified, matched with
// isgm and ranged with the true calibration, each reads within 3 % (the working range's near end).
TEST(RangingPipelineTest, RangesEveryObstacleTypeAt30Cm) {
  for (const sim::ObstacleType type : sim::AllObstacleTypes()) {
    SCOPED_TRACE(sim::ObstacleTypeName(type));
    sim::PowerLineSceneOptions scene_options;
    scene_options.sensor.supersampling = 1;
    scene_options.obstacles = {{type, 0.3, 0}};
    const sim::PowerLineScene scene = sim::RenderPowerLineScene(scene_options);
    ASSERT_EQ(scene.obstacles.size(), 1u);
    const cv::Rect roi = GrowRoi(scene.obstacles.front().box, scene.left.size());
    const RangingPipelineOptions options = IsgmOnOneThread();
    const RangingPipeline pipeline(sim::MakeStereoCalibration(scene_options.rig), options);
    const RangingFrame frame =
        pipeline.Process(scene.left, scene.right, cv::Range(roi.y, roi.br().y));
    const RangeResult r = pipeline.RangeRois(frame, {roi}).front();
    ASSERT_TRUE(r.ok()) << r.reason;
    const double truth = scene.obstacles.front().distance_m;
    EXPECT_NEAR(r.distance_m, truth, 0.03 * truth);
  }
}

// The damper at 4.5 m: its end cap, the nearest surface, is a dark disc about 10 px across with no
// texture of its own, so the surface refinement has no clean pixels to fit and the matched map
// reads it too far. Its outline against the background, measured on each view, gives the
// distance (one noise draw of the default scene, true calibration).
TEST(RangingPipelineTest, ATexturelessFrontIsMeasuredAtItsOutline) {
  sim::PowerLineSceneOptions scene_options;
  scene_options.obstacles = {{sim::ObstacleType::kDamper, 4.5, 0}};
  const sim::PowerLineScene scene = sim::RenderPowerLineScene(scene_options);
  ASSERT_EQ(scene.obstacles.size(), 1u);
  const cv::Rect roi = GrowRoi(scene.obstacles.front().box, scene.left.size());
  RangingPipelineOptions options;
  options.threads = 1;
  const RangingPipeline pipeline(sim::MakeStereoCalibration(scene_options.rig), options);
  const RangingFrame frame =
      pipeline.Process(scene.left, scene.right, cv::Range(roi.y, roi.br().y));
  const RangeResult r = pipeline.RangeRois(frame, {roi}).front();
  ASSERT_TRUE(r.ok()) << r.reason;
  EXPECT_EQ(r.refinement, "edges");
  EXPECT_GT(r.disparity_px, r.matched_disparity_px);  // only ever nearer than the matched map
  const double truth = scene.obstacles.front().distance_m;
  EXPECT_NEAR(r.distance_m, truth, 0.01 * truth);
  EXPECT_LE(std::abs(r.distance_m - truth), 2 * r.sigma_m);
  // The matched map alone reads it farther.
  EXPECT_GT(pipeline.geometry().DepthFromDisparity(r.matched_disparity_px), r.distance_m);
}

}  // namespace
}  // namespace linesight
