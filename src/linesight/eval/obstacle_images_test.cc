#include "linesight/eval/obstacle_images.h"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "linesight/core/error.h"
#include "linesight/eval/eval_test_util.h"
#include "linesight/eval/synthetic_scenes_test_util.h"

namespace linesight {
namespace {

using test::kInf;

struct FullImages {
  cv::Mat left, right, ground_truth, mask;
};

// 200x120 pair: background texture at disparity 6; obstacle id 3 (a 30x20 block at x 120..149,
// y 50..69) at disparity 14 with known ground truth; a 20-row band of "sky" at the top (no ground
// truth).
FullImages MakeImages() {
  const cv::Size size(200, 120);
  const cv::Mat far = testing::SyntheticTexture(cv::Size(size.width + 6, size.height), 5);
  const cv::Mat near = testing::SyntheticTexture(cv::Size(size.width + 14, size.height), 6);
  FullImages im;
  im.left = far(cv::Rect(0, 0, size.width, size.height)).clone();
  im.right = far(cv::Rect(6, 0, size.width, size.height)).clone();
  im.ground_truth = cv::Mat(size, CV_32FC1, cv::Scalar(6.0f));
  im.mask = cv::Mat(size, CV_8UC1, cv::Scalar(0));
  const cv::Rect box(120, 50, 30, 20);
  near(box).copyTo(im.left(box));
  near(box).copyTo(im.right(box - cv::Point(14, 0)));
  im.ground_truth(box).setTo(14.0f);
  im.mask(box).setTo(3);
  im.ground_truth(cv::Rect(0, 0, size.width, 20)).setTo(kInf);
  // A known pixel of another obstacle id inside the margin.
  im.mask.at<uint8_t>(48, 125) = 1;
  return im;
}

TEST(ObstacleImagesTest, CropKeepsGroundTruthAligned) {
  const FullImages im = MakeImages();
  const cv::Rect box(120, 50, 30, 20);
  const ObstacleCropGeometry g = ObstacleCropFor(im.ground_truth, box, 5);
  EXPECT_EQ(g.evaluation_box, cv::Rect(115, 45, 40, 30));
  // ceil(1.1 * 14) + 1 = 17 -> 32.
  EXPECT_EQ(g.num_disparities, 32);
  EXPECT_EQ(g.crop, cv::Rect(115 - 32, 45, 40 + 32, 30));

  const StereoScene scene =
      CropObstacleScene(im.left, im.right, im.ground_truth, im.mask, 3, box, 5, "block@1m");
  EXPECT_EQ(scene.ref.set, kObstacleSetName);
  EXPECT_EQ(scene.ref.name, "block@1m");
  EXPECT_EQ(scene.num_disparities, 32);
  ASSERT_EQ(scene.ground_truth.size(), g.crop.size());
  int obstacle_pixels = 0, all_pixels = 0;
  for (int y = 0; y < g.crop.height; ++y) {
    for (int x = 0; x < g.crop.width; ++x) {
      const cv::Point full(x + g.crop.x, y + g.crop.y);
      const float gt = scene.ground_truth.at<float>(y, x);
      const float expected = im.ground_truth.at<float>(full);
      if (std::isfinite(expected)) {
        EXPECT_EQ(gt, expected);
      } else {
        EXPECT_FALSE(std::isfinite(gt));
      }
      EXPECT_EQ(scene.left.at<cv::Vec3b>(y, x), im.left.at<cv::Vec3b>(full));
      EXPECT_EQ(scene.right.at<cv::Vec3b>(y, x), im.right.at<cv::Vec3b>(full));
      const bool in_eval = g.evaluation_box.contains(full);
      const bool is_obstacle = scene.masks.at("obstacle").at<uint8_t>(y, x) == 255;
      const bool is_all = scene.masks.at("all").at<uint8_t>(y, x) == 255;
      EXPECT_EQ(is_obstacle, in_eval && im.mask.at<uint8_t>(full) == 3);
      EXPECT_EQ(is_all, in_eval && std::isfinite(expected));
      obstacle_pixels += is_obstacle;
      all_pixels += is_all;
    }
  }
  EXPECT_EQ(obstacle_pixels, 30 * 20);
  EXPECT_EQ(all_pixels, 40 * 30);  // sky band ends at y = 20, above the evaluation box
}

TEST(ObstacleImagesTest, CropIsClippedAtTheImageBorder) {
  const FullImages im = MakeImages();
  const cv::Rect box(2, 100, 10, 20);
  const ObstacleCropGeometry g = ObstacleCropFor(im.ground_truth, box, 8);
  EXPECT_EQ(g.evaluation_box, cv::Rect(0, 92, 20, 28));
  EXPECT_EQ(g.crop.x, 0);
  EXPECT_EQ(g.crop.br().x, 20);
}

TEST(ObstacleImagesTest, BadInputIsRejected) {
  const FullImages im = MakeImages();
  EXPECT_THROW(ObstacleCropFor(im.ground_truth, cv::Rect(190, 0, 20, 10), 0), InputError);
  EXPECT_THROW(ObstacleCropFor(im.ground_truth, cv::Rect(0, 0, 0, 10), 0), InputError);
  EXPECT_THROW(ObstacleCropFor(im.ground_truth, cv::Rect(0, 0, 10, 10), -1), InputError);
  EXPECT_THROW(CropObstacleScene(im.left, im.right(cv::Rect(0, 0, 100, 100)), im.ground_truth,
                                 im.mask, 3, cv::Rect(0, 0, 10, 10), 0, "x"),
               InputError);
}

TEST(ObstacleImagesTest, OptionsDefaultsValidAndBoundaries) {
  EXPECT_NO_THROW(ObstacleImageOptions().Check());
  ObstacleImageOptions o;
  o.supersampling = 0;
  EXPECT_THROW(o.Check(), OptionError);
  o = ObstacleImageOptions();
  o.margin_px = -1;
  EXPECT_THROW(o.Check(), OptionError);
  o = ObstacleImageOptions();
  o.obstacles.clear();
  EXPECT_THROW(o.Check(), OptionError);
  EXPECT_NO_THROW(EvalObstaclesOptions().Check());
  EvalObstaclesOptions e;
  e.noise.clear();
  EXPECT_THROW(e.Check(), OptionError);
}

TEST(ObstacleImagesTest, MatchersScoreTheCropAgainstItsGroundTruth) {
  const FullImages im = MakeImages();
  const StereoScene scene = CropObstacleScene(im.left, im.right, im.ground_truth, im.mask, 3,
                                              cv::Rect(120, 50, 30, 20), 5, "block@1m");
  EvalObstaclesOptions options;
  options.methods = {"sgbm"};
  options.noise = {NoiseSpec(), NoiseSpec::Parse("sp:0.35")};
  options.threads = 1;
  const EvalObstaclesReport report = RunEvalObstacles({scene}, options);
  ASSERT_EQ(report.results.size(), 2u);
  const DisparityMetrics& clean = report.results[0].regions.at("obstacle");
  EXPECT_EQ(clean.evaluated, 30 * 20);
  // The shifted block is found (its inner part at least; the ring near the depth edge may miss).
  EXPECT_LT(clean.bad[1], 35.0);
  EXPECT_GT(report.results[1].regions.at("obstacle").bad[1], clean.bad[1]);
  const std::string markdown = report.ToMarkdown();
  EXPECT_NE(markdown.find("block@1m"), std::string::npos);
  EXPECT_NE(markdown.find("sp:0.35"), std::string::npos);
  testing::ScopedTempDir dir;
  EXPECT_EQ(report.WritePlots(dir.path()).size(), 1u);
}

}  // namespace
}  // namespace linesight
