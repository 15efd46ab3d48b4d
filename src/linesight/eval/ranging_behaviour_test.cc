// Behaviour of the ranging chain, specified on pairs from the plate renderer (sim/plate_scene.h),
// not on study cells: what a user may rely on whatever the scene.
#include <cmath>
#include <filesystem>
#include <vector>

#include <gtest/gtest.h>

#include "linesight/eval/eval_test_util.h"
#include "linesight/io/image_io.h"
#include "linesight/ranging/pipeline.h"
#include "linesight/sim/plate_scene.h"

namespace linesight {
namespace {

namespace fs = std::filesystem;

using test::kOpenCvData;

bool HaveTextures() {
  return fs::exists(kOpenCvData / "graf1.png") && fs::exists(kOpenCvData / "leuvenA.jpg");
}

// A fronto-parallel textured plate at `distance_m` in front of a textured wall, one capture.
struct PlatePair {
  sim::PlateRendering scene;
  cv::Mat left, right;
};

PlatePair RenderPlate(double distance_m, std::uint64_t seed) {
  sim::PlateSceneSpec spec;
  spec.shape = sim::PlateShape::kPlate;
  spec.distance_m = distance_m;
  spec.plate_texture = ReadImage(kOpenCvData / "graf1.png", ImageColor::kColor);
  spec.background_texture = ReadImage(kOpenCvData / "leuvenA.jpg", ImageColor::kColor);
  spec.supersampling = 2;
  spec.centre_px = {0.70 * spec.rig.image_size.width, 0.45 * spec.rig.image_size.height};
  PlatePair pair;
  pair.scene = sim::RenderPlateScene(spec);
  pair.left = sim::CapturePlateImage(pair.scene.left, 1.0, seed);
  pair.right = sim::CapturePlateImage(pair.scene.right, 1.0, seed + 1);
  return pair;
}

RangingPipeline PlatePipeline() {
  RangingPipelineOptions options;
  options.input_rectified = true;
  return RangingPipeline(sim::PlateRig{}.Calibration(), options);
}

// How much wall the ROI holds around the object does not change the reading beyond its sigma.
TEST(RangingBehaviourTest, ThePlateReadsTheSameWhateverTheRoiMargin) {
  if (!HaveTextures()) GTEST_SKIP() << "opencv-doc sample images not found at " << kOpenCvData;
  const RangingPipeline pipeline = PlatePipeline();
  const PlatePair pair = RenderPlate(2.0, 11);
  const RangingFrame frame = pipeline.Process(pair.left, pair.right);
  const cv::Size size = pair.left.size();
  std::vector<RangeResult> results;
  for (const int margin : {4, 12, 24, 48}) {
    const cv::Rect roi = GrowRoiByPixels(pair.scene.box, margin, margin, size);
    results.push_back(pipeline.RangeRois(frame, {roi}).front());
    ASSERT_TRUE(results.back().ok()) << "margin " << margin << ": " << results.back().reason;
  }
  for (const RangeResult& r : results) {
    SCOPED_TRACE(r.roi);
    EXPECT_NEAR(r.distance_m, results.front().distance_m,
                std::max(r.sigma_m, results.front().sigma_m));
    EXPECT_NEAR(r.distance_m, pair.scene.distance_m, 0.01 * pair.scene.distance_m);
  }
}

// A plate farther away reads farther: the readings grow with the true depth.
TEST(RangingBehaviourTest, ReadingsGrowWithTheTrueDepth) {
  if (!HaveTextures()) GTEST_SKIP() << "opencv-doc sample images not found at " << kOpenCvData;
  const RangingPipeline pipeline = PlatePipeline();
  double previous = 0.0;
  for (const double distance : {0.6, 1.0, 1.6, 2.5, 4.0, 6.0}) {
    const PlatePair pair = RenderPlate(distance, 21);
    const RangingFrame frame = pipeline.Process(pair.left, pair.right);
    const cv::Rect roi = GrowRoi(pair.scene.box, pair.left.size());
    const RangeResult r = pipeline.RangeRois(frame, {roi}).front();
    ASSERT_TRUE(r.ok()) << distance << " m: " << r.reason;
    EXPECT_GT(r.distance_m, previous) << "plate at " << distance << " m";
    EXPECT_NEAR(r.distance_m, pair.scene.distance_m, 0.015 * pair.scene.distance_m);
    previous = r.distance_m;
  }
}

// Without a measurement the result says why, and carries no distance.
TEST(RangingBehaviourTest, NoMeasurementSaysWhy) {
  if (!HaveTextures()) GTEST_SKIP() << "opencv-doc sample images not found at " << kOpenCvData;
  RangingPipelineOptions options;
  options.input_rectified = true;
  options.max_depth_m = 1.0;  // the plate at 2 m and the wall behind it are beyond
  const RangingPipeline pipeline(sim::PlateRig{}.Calibration(), options);
  const PlatePair pair = RenderPlate(2.0, 31);
  const RangingFrame frame = pipeline.Process(pair.left, pair.right);
  const RangeResult r =
      pipeline.RangeRois(frame, {GrowRoi(pair.scene.box, pair.left.size())}).front();
  EXPECT_FALSE(r.ok());
  EXPECT_FALSE(r.reason.empty());
  EXPECT_EQ(r.distance_m, 0.0);
}

}  // namespace
}  // namespace linesight
