#include "linesight/ranging/surface_refinement.h"

#include <cmath>

#include <gtest/gtest.h>

#include "linesight/core/error.h"

namespace linesight {
namespace {

// Smooth analytic texture (sum of sinusoids below 0.9 rad/px), so that a shifted copy is exact.
double Texture(double x, double y, int seed) {
  double v = 0.0;
  for (int k = 0; k < 6; ++k) {
    const double wx = 0.15 + 0.12 * k + 0.03 * seed, wy = 0.1 + 0.07 * ((k * 3 + seed) % 5);
    v += std::sin(wx * x + wy * y + 1.7 * k + seed);
  }
  return 128.0 + 18.0 * v;
}

// A rectified pair: a fronto-parallel patch (x in [60, 140), y in [40, 80)) at disparity
// `patch_d` in front of a background at disparity 3 (another texture). Returns the patch pixels.
std::vector<cv::Point> MakePair(double patch_d, cv::Mat* left, cv::Mat* right) {
  *left = cv::Mat(120, 200, CV_8U);
  *right = cv::Mat(120, 200, CV_8U);
  auto in_patch = [](double x, double y) { return x >= 60 && x < 140 && y >= 40 && y < 80; };
  for (int y = 0; y < 120; ++y) {
    for (int x = 0; x < 200; ++x) {
      left->at<uchar>(y, x) =
          cv::saturate_cast<uchar>(in_patch(x, y) ? Texture(x, y, 0) : Texture(x, y, 3));
      // Right pixel x sees the patch point at left x + patch_d, else the background at x + 3.
      const double xl = x + patch_d;
      right->at<uchar>(y, x) =
          cv::saturate_cast<uchar>(in_patch(xl, y) ? Texture(xl, y, 0) : Texture(x + 3.0, y, 3));
    }
  }
  std::vector<cv::Point> pixels;
  for (int y = 40; y < 80; ++y)
    for (int x = 60; x < 140; ++x) pixels.push_back({x, y});
  return pixels;
}

TEST(SurfaceRefinementTest, RecoversTheDisparityOfAShiftedPatch) {
  for (double d : {12.3, 20.75}) {
    cv::Mat left, right;
    const std::vector<cv::Point> pixels = MakePair(d, &left, &right);
    // Start 0.8 px off (the matcher's bias on thin fronts).
    const SurfaceRefinement r =
        RefineSurfaceDisparity(left, right, pixels, d - 0.8, SurfaceRefinementOptions());
    ASSERT_TRUE(r.ok) << r.reason;
    EXPECT_NEAR(r.disparity_px, d, 0.03);
    EXPECT_GT(r.ncc, 0.99);
    EXPECT_EQ(r.pixels, int(pixels.size()));
    EXPECT_GT(r.sigma_px, 0.0);
    EXPECT_LT(r.sigma_px, 0.02);
  }
}

TEST(SurfaceRefinementTest, BgrImagesGiveTheSameAnswer) {
  cv::Mat left, right, left_bgr, right_bgr;
  const std::vector<cv::Point> pixels = MakePair(15.4, &left, &right);
  cv::Mat channels_l[] = {left, left, left}, channels_r[] = {right, right, right};
  cv::merge(channels_l, 3, left_bgr);
  cv::merge(channels_r, 3, right_bgr);
  const SurfaceRefinement grey =
      RefineSurfaceDisparity(left, right, pixels, 15.0, SurfaceRefinementOptions());
  const SurfaceRefinement bgr =
      RefineSurfaceDisparity(left_bgr, right_bgr, pixels, 15.0, SurfaceRefinementOptions());
  ASSERT_TRUE(grey.ok && bgr.ok);
  EXPECT_NEAR(grey.disparity_px, bgr.disparity_px, 1e-3);
}

TEST(SurfaceRefinementTest, RefusesWhatItCannotMeasure) {
  cv::Mat left, right;
  const std::vector<cv::Point> pixels = MakePair(12.3, &left, &right);
  // The true disparity lies outside the search window: the peak sits at its edge.
  SurfaceRefinementOptions narrow;
  narrow.search_px = 0.5;
  narrow.search_relative = 0.0;
  const SurfaceRefinement at_edge = RefineSurfaceDisparity(left, right, pixels, 10.0, narrow);
  EXPECT_FALSE(at_edge.ok);
  // The correlation rises towards the true 12.3 px: highest at the window's upper end, reported.
  EXPECT_TRUE(at_edge.at_search_edge);
  EXPECT_NEAR(at_edge.disparity_px, 10.5, 1e-9);
  EXPECT_GT(at_edge.ncc, 0.0);
  // A textureless surface has no correlation peak.
  const cv::Mat flat(120, 200, CV_8U, cv::Scalar(90));
  const SurfaceRefinement f =
      RefineSurfaceDisparity(flat, flat, pixels, 12.0, SurfaceRefinementOptions());
  EXPECT_FALSE(f.ok);
  // (Every correlation is undefined: if reported as an edge, its NCC is far below the gate.)
  EXPECT_TRUE(!f.at_search_edge || f.ncc < SurfaceRefinementOptions().min_ncc);
  EXPECT_FALSE(f.reason.empty());
  // Too few pixels.
  const std::vector<cv::Point> few(pixels.begin(), pixels.begin() + 5);
  EXPECT_FALSE(RefineSurfaceDisparity(left, right, few, 12.0, SurfaceRefinementOptions()).ok);
  // Pixels whose match would leave the right image are not used.
  const std::vector<cv::Point> edge = {{2, 50}, {3, 50}, {4, 50}};
  EXPECT_EQ(RefineSurfaceDisparity(left, right, edge, 12.0, SurfaceRefinementOptions()).pixels, 0);
}

TEST(SurfaceRefinementTest, BadInputAndOptions) {
  cv::Mat left, right;
  const std::vector<cv::Point> pixels = MakePair(12.3, &left, &right);
  EXPECT_THROW(RefineSurfaceDisparity(left, right.colRange(0, 100), pixels, 12.0,
                                      SurfaceRefinementOptions()),
               InputError);
  EXPECT_THROW(RefineSurfaceDisparity(cv::Mat(), right, pixels, 12.0, SurfaceRefinementOptions()),
               InputError);
  SurfaceRefinementOptions o;
  o.step_px = 0.0;
  EXPECT_THROW(o.Check(), OptionError);
  o = SurfaceRefinementOptions();
  o.min_ncc = 1.0;
  EXPECT_THROW(o.Check(), OptionError);
}

}  // namespace
}  // namespace linesight
