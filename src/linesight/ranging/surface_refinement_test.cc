#include "linesight/ranging/surface_refinement.h"

#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "linesight/core/error.h"
#include "linesight/core/option_test_util.h"

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

// Every pixel of S, no gradient or interior selection.
SurfaceRefinementOptions AllPixels() {
  SurfaceRefinementOptions o;
  o.gradient_ratio = 0.0;
  o.interior_only = false;
  return o;
}

TEST(SurfaceRefinementTest, RecoversTheDisparityOfAShiftedPatch) {
  for (double d : {12.3, 20.75}) {
    for (const SurfaceRefinementOptions& options : {SurfaceRefinementOptions(), AllPixels()}) {
      cv::Mat left, right;
      const std::vector<cv::Point> pixels = MakePair(d, &left, &right);
      // Start 0.8 px off (the matcher's bias on thin fronts).
      const SurfaceRefinement r = RefineSurfaceDisparity(left, right, pixels, d - 0.8, options);
      ASSERT_TRUE(r.ok) << r.reason;
      EXPECT_NEAR(r.disparity_px, d, 0.03);
      EXPECT_GT(r.ncc, 0.99);
      EXPECT_GT(r.sigma_px, 0.0);
      EXPECT_LT(r.sigma_px, 0.02);
      if (options.interior_only) {
        // Interior of the 80 x 40 patch, and of those the pixels with a mostly horizontal gradient.
        EXPECT_LT(r.pixels, 78 * 38);
        EXPECT_GT(r.pixels, 78 * 38 / 5);
      } else {
        EXPECT_EQ(r.pixels, int(pixels.size()));
      }
    }
  }
}

// S's border is left out with interior_only: a ring of background pixels around the patch (what
// a matcher's fattening adds to a surface set) no longer enters the fit.
TEST(SurfaceRefinementTest, InteriorOnlyDropsTheBorderOfTheSet) {
  cv::Mat left, right;
  MakePair(12.3, &left, &right);
  std::vector<cv::Point> pixels;  // the patch grown by 1 px: a ring of background
  for (int y = 39; y < 81; ++y)
    for (int x = 59; x < 141; ++x) pixels.push_back({x, y});
  SurfaceRefinementOptions interior = AllPixels();
  interior.interior_only = true;
  const SurfaceRefinement r = RefineSurfaceDisparity(left, right, pixels, 12.0, interior);
  ASSERT_TRUE(r.ok) << r.reason;
  EXPECT_EQ(r.pixels, 80 * 40);  // exactly the patch
  EXPECT_NEAR(r.disparity_px, 12.3, 0.03);
  // With the ring the fit mixes two surfaces: a lower correlation peak.
  const SurfaceRefinement all = RefineSurfaceDisparity(left, right, pixels, 12.0, AllPixels());
  EXPECT_EQ(all.pixels, int(pixels.size()));
  EXPECT_LT(all.ncc, r.ncc);
}

// A vertical misalignment of the pair (an estimated calibration's rectification error) on a
// texture of near-horizontal stripes: matched along the row, every stripe pixel reads
// dy * (dI/dy) / (dI/dx) too far or near. Keeping only pixels whose gradient is mostly horizontal
// leaves the vertical texture, which is unaffected.
TEST(SurfaceRefinementTest, GradientRatioRemovesTheBiasOfAVerticalMisalignment) {
  const double d = 14.2, dy = 0.15, slope = 0.12;  // stripes y = slope * x + c
  auto texture = [&](double x, double y) {
    return 128.0 + 60.0 * std::sin(2.0 * M_PI * (y - slope * x) / 9.0) + 6.0 * std::sin(0.9 * x) +
           4.0 * std::sin(0.37 * x + 1.0);
  };
  cv::Mat left(120, 200, CV_32F), right(120, 200, CV_32F);
  for (int y = 0; y < 120; ++y) {
    for (int x = 0; x < 200; ++x) {
      left.at<float>(y, x) = float(texture(x, y));
      right.at<float>(y, x) = float(texture(x + d, y + dy));  // right sees the scene dy lower
    }
  }
  cv::Mat left8, right8;
  left.convertTo(left8, CV_8U);
  right.convertTo(right8, CV_8U);
  std::vector<cv::Point> pixels;
  for (int y = 30; y < 90; ++y)
    for (int x = 50; x < 150; ++x) pixels.push_back({x, y});
  SurfaceRefinementOptions all = AllPixels();
  all.min_ncc = 0.5;
  SurfaceRefinementOptions aperture = all;
  aperture.gradient_ratio = 1.0;
  const SurfaceRefinement biased = RefineSurfaceDisparity(left8, right8, pixels, d, all);
  const SurfaceRefinement clean = RefineSurfaceDisparity(left8, right8, pixels, d, aperture);
  ASSERT_TRUE(clean.ok) << clean.reason;
  ASSERT_TRUE(biased.ok || biased.at_search_edge) << biased.reason;
  EXPECT_GT(std::abs(biased.disparity_px - d), 0.3);
  EXPECT_LT(std::abs(clean.disparity_px - d), 0.5 * std::abs(biased.disparity_px - d));
  EXPECT_LT(clean.pixels, biased.pixels);
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
  EXPECT_EQ(RefineSurfaceDisparity(left, right, edge, 12.0, AllPixels()).pixels, 0);
}

TEST(SurfaceRefinementTest, BadInputAndOptions) {
  cv::Mat left, right;
  const std::vector<cv::Point> pixels = MakePair(12.3, &left, &right);
  EXPECT_THROW(RefineSurfaceDisparity(left, right.colRange(0, 100), pixels, 12.0,
                                      SurfaceRefinementOptions()),
               InputError);
  EXPECT_THROW(RefineSurfaceDisparity(cv::Mat(), right, pixels, 12.0, SurfaceRefinementOptions()),
               InputError);
  using testing::ExpectCheckRejects;
  ExpectCheckRejects<SurfaceRefinementOptions>([](auto& o) { o.step_px = 0.0; });
  ExpectCheckRejects<SurfaceRefinementOptions>([](auto& o) { o.min_ncc = 1.0; });
  ExpectCheckRejects<SurfaceRefinementOptions>([](auto& o) { o.gradient_ratio = -1.0; });
}

// A textureless dark front (x in [fx0, fx1), rows 40..59, grey 75) at disparity d in front of a
// slowly varying bright background at disparity 3, area-sampled exactly (each pixel's value mixes
// the surfaces by their overlap with the pixel's extent) -- the damper's end cap in small. With
// `body`, an equally dark surface 1.3 px farther adjoins the front's right side (the weight's body
// beside the cap), so that edge has no contrast.
struct EdgePair {
  cv::Mat left, right;
  std::vector<cv::Point> pixels;  // S: the front shrunk by 3 px (the silhouette margin)
};
EdgePair MakeEdgePair(double d, double fx0, double fx1, bool body) {
  auto overlap = [](double x, double a, double b) {
    return std::max(0.0, std::min(x + 0.5, b) - std::max(x - 0.5, a));
  };
  // shift: the right view sees the front `d` and the body `d - 1.3` further left.
  auto render = [&](cv::Mat* image, double shift, double body_shift, double background_shift) {
    *image = cv::Mat(100, 160, CV_8U);
    for (int y = 0; y < 100; ++y) {
      for (int x = 0; x < 160; ++x) {
        const bool rows = y >= 40 && y < 60;
        const double front = rows ? overlap(x, fx0 - shift, fx1 - shift) : 0.0;
        const double dark = rows && body ? overlap(x, fx1 - body_shift, fx1 + 8 - body_shift) : 0.0;
        const double cover = std::min(1.0, front + dark);  // the body lies behind the front
        const double background = 150.0 + 25.0 * std::sin(0.02 * (x + background_shift) + 0.03 * y);
        image->at<uchar>(y, x) = cv::saturate_cast<uchar>(cover * 75.0 + (1 - cover) * background);
      }
    }
  };
  EdgePair pair;
  render(&pair.left, 0.0, 0.0, 0.0);
  render(&pair.right, d, d - 1.3, 3.0);
  for (int y = 43; y < 57; ++y)
    for (int x = int(std::ceil(fx0)) + 3; x < int(fx1) - 3; ++x) pair.pixels.push_back({x, y});
  return pair;
}

TEST(EdgeDisparityTest, RecoversATexturelessFrontFromItsOutline) {
  for (double d : {12.3, 19.72, 25.05}) {
    const EdgePair pair = MakeEdgePair(d, 80.35, 90.8, false);
    // The correlation fit has nothing to fit inside the front.
    EXPECT_FALSE(RefineSurfaceDisparity(pair.left, pair.right, pair.pixels, d - 0.4,
                                        SurfaceRefinementOptions())
                     .ok);
    // Started 0.4 px off, as the matcher reads such a front.
    const EdgeDisparity e =
        MeasureEdgeDisparity(pair.left, pair.right, pair.pixels, d - 0.4, EdgeDisparityOptions());
    ASSERT_TRUE(e.ok) << e.reason;
    EXPECT_NEAR(e.disparity_px, d, 0.03) << d;  // 8-bit levels, a background slope of 0.5 DN/px
    EXPECT_EQ(e.side, 0);                       // both ends, in agreement
    EXPECT_EQ(e.rows, 40);                      // S's 14 rows and the 3 beyond, at each end
    EXPECT_LT(e.sigma_px, 0.01);
  }
}

// Every subpixel phase of the edges in both views: a pixel the edge barely covers differs from its
// plateau by less than the noise threshold, and must still count.
TEST(EdgeDisparityTest, EverySubpixelPhaseIsMeasured) {
  for (int k = 0; k < 20; ++k) {
    const double fx0 = 80.0 + 0.05 * k, d = 19.72;
    const EdgePair pair = MakeEdgePair(d, fx0, fx0 + 10.4, false);
    const EdgeDisparity e =
        MeasureEdgeDisparity(pair.left, pair.right, pair.pixels, d - 0.4, EdgeDisparityOptions());
    ASSERT_TRUE(e.ok) << e.reason;
    EXPECT_EQ(e.side, 0) << fx0;  // both ends, in agreement
    EXPECT_NEAR(e.disparity_px, d, 0.03) << fx0;
  }
}

TEST(EdgeDisparityTest, AnEdgeWithoutContrastGivesNothing) {
  const double d = 19.72;
  const EdgePair pair = MakeEdgePair(d, 80.35, 90.8, true);
  const EdgeDisparity e =
      MeasureEdgeDisparity(pair.left, pair.right, pair.pixels, d - 0.4, EdgeDisparityOptions());
  ASSERT_TRUE(e.ok) << e.reason;
  EXPECT_EQ(e.side, -1);  // only the left edge, against the background
  EXPECT_EQ(e.right_rows, 0);
  EXPECT_EQ(e.left_rows, 20);
  EXPECT_NEAR(e.disparity_px, d, 0.03);
  // With the matched value far off (more than the gate), no row is accepted.
  const EdgeDisparity off =
      MeasureEdgeDisparity(pair.left, pair.right, pair.pixels, d - 2.5, EdgeDisparityOptions());
  EXPECT_FALSE(off.ok);
  EXPECT_FALSE(off.reason.empty());
  // A matched disparity that is not a number, or not inside the image, gives nothing.
  EXPECT_FALSE(
      MeasureEdgeDisparity(pair.left, pair.right, pair.pixels, std::nan(""), EdgeDisparityOptions())
          .ok);
  EXPECT_FALSE(
      MeasureEdgeDisparity(pair.left, pair.right, pair.pixels, 1e300, EdgeDisparityOptions()).ok);
  // BGR images give the same answer.
  cv::Mat left_bgr, right_bgr;
  cv::cvtColor(pair.left, left_bgr, cv::COLOR_GRAY2BGR);
  cv::cvtColor(pair.right, right_bgr, cv::COLOR_GRAY2BGR);
  EXPECT_NEAR(
      MeasureEdgeDisparity(left_bgr, right_bgr, pair.pixels, d - 0.4, EdgeDisparityOptions())
          .disparity_px,
      e.disparity_px, 1e-3);
  // A uniform image has no edges.
  const cv::Mat flat(100, 160, CV_8U, cv::Scalar(90));
  EXPECT_FALSE(MeasureEdgeDisparity(flat, flat, pair.pixels, d, EdgeDisparityOptions()).ok);
  EXPECT_FALSE(MeasureEdgeDisparity(flat, flat, {}, d, EdgeDisparityOptions()).ok);
}

// A front with texture of its own (a bright column every 4 px, the first 3.65 px inside its left
// edge) has no flat surface plateau beside its edges: with the default 3-pixel surface plateau
// nothing is measured (the correlation fit is what measures a textured surface); a 1-pixel
// plateau accepts the left edge.
TEST(EdgeDisparityTest, ATexturedSurfaceHasNoPlateau) {
  const int d = 19;
  const double fx0 = 80.35, fx1 = 90.8;
  auto render = [&](cv::Mat* image, int shift) {
    *image = cv::Mat(100, 160, CV_8U);
    for (int y = 0; y < 100; ++y) {
      for (int x = 0; x < 160; ++x) {
        const int u = x + shift;  // the left view's column this pixel sees
        const double front = y >= 40 && y < 60
                                 ? std::max(0.0, std::min(u + 0.5, fx1) - std::max(u - 0.5, fx0))
                                 : 0.0;
        const double level = (u - 81) % 4 == 3 ? 100.0 : 75.0;
        image->at<uchar>(y, x) = cv::saturate_cast<uchar>(front * level + (1 - front) * 150.0);
      }
    }
  };
  cv::Mat left, right;
  render(&left, 0);
  render(&right, d);
  std::vector<cv::Point> pixels;
  for (int y = 43; y < 57; ++y)
    for (int x = 85; x < 88; ++x) pixels.push_back({x, y});  // S's ends on the dark level
  EXPECT_FALSE(MeasureEdgeDisparity(left, right, pixels, d - 0.4, EdgeDisparityOptions()).ok);
  EdgeDisparityOptions one_pixel;
  one_pixel.surface_plateau_px = 1;
  const EdgeDisparity e = MeasureEdgeDisparity(left, right, pixels, d - 0.4, one_pixel);
  ASSERT_TRUE(e.ok) << e.reason;
  EXPECT_EQ(e.side, -1);
  EXPECT_NEAR(e.disparity_px, d, 0.03);
}

TEST(EdgeDisparityTest, BadInputAndOptions) {
  const EdgePair pair = MakeEdgePair(12.3, 80.35, 90.8, false);
  EXPECT_THROW(MeasureEdgeDisparity(pair.left, pair.right.colRange(0, 100), pair.pixels, 12.0,
                                    EdgeDisparityOptions()),
               InputError);
  EXPECT_THROW(
      MeasureEdgeDisparity(cv::Mat(), pair.right, pair.pixels, 12.0, EdgeDisparityOptions()),
      InputError);
  cv::Mat left16, right16;
  pair.left.convertTo(left16, CV_16U);
  pair.right.convertTo(right16, CV_16U);
  EXPECT_THROW(MeasureEdgeDisparity(left16, right16, pair.pixels, 12.0, EdgeDisparityOptions()),
               InputError);
  testing::ExpectCheckRejects<EdgeDisparityOptions>([](auto& o) { o.min_rows = 0; });
  testing::ExpectCheckRejects<EdgeDisparityOptions>([](auto& o) { o.level_tolerance = 0.0; });
}

}  // namespace
}  // namespace linesight
