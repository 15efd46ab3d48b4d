#include "linesight/ranging/thin_structures.h"

#include <random>

#include <gtest/gtest.h>
#include <hwy/tests/hwy_gtest.h>
#include <opencv2/imgproc.hpp>

#include "linesight/core/disparity.h"
#include "linesight/core/error.h"
#include "linesight/ranging/ranging_test_util.h"
#include "linesight/ranging/thin_structures_reference.h"

// The morphology's SIMD kernel (row_runs.h) runs on every Highway target this CPU supports (outside
// namespace linesight, whose `testing` would hide gtest's in the macro).
class MorphologyKernelTest : public hwy::TestWithParamTarget {};
HWY_TARGET_INSTANTIATE_TEST_SUITE_P(MorphologyKernelTest);

namespace linesight {
namespace {

TEST(ThinStructureOptionsTest, DefaultsAreValidAndBoundsAreChecked) {
  EXPECT_NO_THROW(ThinStructureOptions{}.Check());
  EXPECT_THROW((ThinStructureOptions{.min_width_m = 0.0}.Check()), OptionError);
  EXPECT_THROW((ThinStructureOptions{.depth_band_relative = 0.0}.Check()), OptionError);
  EXPECT_THROW((ThinStructureOptions{.min_depth_m = 2.0, .max_depth_m = 1.0}.Check()), OptionError);
}

// Random masks with blobs, lines and speckle, touching the borders.
cv::Mat RandomMask(cv::Size size, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  cv::Mat mask(size, CV_8U, cv::Scalar(0));
  for (int i = 0; i < 6; ++i) {
    const cv::Point c(int(unit(rng) * size.width), int(unit(rng) * size.height));
    cv::circle(mask, c, 1 + int(unit(rng) * 30), cv::Scalar(255), cv::FILLED);
    cv::line(mask, c, {int(unit(rng) * size.width), int(unit(rng) * size.height)}, cv::Scalar(255),
             1 + int(unit(rng) * 4));
  }
  for (int y = 0; y < size.height; ++y) {
    for (int x = 0; x < size.width; ++x) {
      if (unit(rng) < 0.02) mask.at<std::uint8_t>(y, x) ^= 255;
    }
  }
  return mask;
}

TEST_P(MorphologyKernelTest, EllipseEqualsOpenCvMorphologyOnAwkwardSizes) {
  const cv::Size sizes[] = {{1, 1}, {3, 97}, {97, 3}, {61, 43}, {130, 77}};
  std::uint64_t seed = 1;
  cv::Mat fast, naive;
  EllipseScratch scratch;
  for (const cv::Size size : sizes) {
    const cv::Mat mask = RandomMask(size, seed++);
    for (const int n : {1, 3, 5, 7, 9, 15, 31, 57, 101, 151}) {
      const cv::Mat element = cv::getStructuringElement(cv::MORPH_ELLIPSE, {n, n});
      DilateEllipse(mask, n, &fast, &scratch);
      cv::dilate(mask, naive, element);
      EXPECT_EQ(cv::countNonZero(fast != naive), 0) << "dilate " << size << " n " << n;
      ErodeEllipse(mask, n, &fast, &scratch);
      cv::erode(mask, naive, element);
      EXPECT_EQ(cv::countNonZero(fast != naive), 0) << "erode " << size << " n " << n;
      CloseEllipse(mask, n, &fast, &scratch);
      cv::morphologyEx(mask, naive, cv::MORPH_CLOSE, element);
      EXPECT_EQ(cv::countNonZero(fast != naive), 0) << "close " << size << " n " << n;
    }
  }
}

TEST_P(MorphologyKernelTest, NearerThanEqualsOpenCvsDistanceTransformOnAwkwardSizes) {
  const cv::Size sizes[] = {{1, 1}, {2, 67}, {67, 2}, {61, 43}, {130, 77}, {203, 150}};
  std::uint64_t seed = 11;
  cv::Mat fast, distance;
  EllipseScratch scratch;
  for (const cv::Size size : sizes) {
    // Sparse and dense clear pixels: the balls' whole rims are exercised.
    for (const int density : {0, 1, 2}) {
      cv::Mat off = RandomMask(size, seed++);
      if (density == 1) {
        off &= RandomMask(size, seed++);
        off &= RandomMask(size, seed++);
      }
      if (density == 2) off.setTo(0);
      if (density == 2 && size.area() > 4)
        off.at<std::uint8_t>(size.height / 2, size.width / 3) = 255;
      cv::Mat surface;
      cv::compare(off, 0, surface, cv::CMP_EQ);
      cv::distanceTransform(surface, distance, cv::DIST_L2, cv::DIST_MASK_5);
      for (const double radius : {0.3, 1.0, 1.2, 1.4, 1.5, 2.0, 2.1969, 2.5, 3.0, 3.7, 5.5, 7.0,
                                  12.9, 20.0, 33.6, 56.6, 260.0}) {
        NearerThan(off, radius, &fast, &scratch);
        const cv::Mat naive = distance < radius;
        EXPECT_EQ(cv::countNonZero(fast != naive), 0)
            << size << " density " << density << " radius " << radius;
      }
    }
  }
}

// Random blocks, bars and thin lines at random depths, with holes, touching the image borders.
cv::Mat RandomScene(cv::Size size, const StereoGeometry& g, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  cv::Mat disparity(size, CV_32F, cv::Scalar(kInvalidDisparity));
  for (int i = 0; i < 14; ++i) {
    const double z = 0.3 + 9.0 * unit(rng);
    const int w = 1 + int(unit(rng) * (i % 3 == 0 ? size.width : 60));
    const int h = 1 + int(unit(rng) * (i % 3 == 1 ? size.height : 50));
    const int x = int(unit(rng) * size.width) - w / 3, y = int(unit(rng) * size.height) - h / 3;
    const cv::Rect r = cv::Rect(x, y, w, h) & cv::Rect(0, 0, size.width, size.height);
    if (r.empty()) continue;
    // A slanted surface: the disparity varies across it by up to 10 %.
    const double d0 = g.DisparityFromDepth(z), slope = 0.1 * d0 * (unit(rng) - 0.5) / size.width;
    for (int yy = r.y; yy < r.br().y; ++yy) {
      for (int xx = r.x; xx < r.br().x; ++xx) {
        disparity.at<float>(yy, xx) =
            unit(rng) < 0.03 ? kInvalidDisparity : float(d0 + slope * (xx - r.x));
      }
    }
  }
  return disparity;
}

TEST(BodyMaskTest, EqualsTheWholeViewReferenceOnAwkwardSizesAndRegions) {
  const StereoGeometry g = testing::TestGeometry();
  const cv::Size sizes[] = {{1, 1}, {7, 300}, {333, 5}, {257, 191}, {301, 203}};
  std::uint64_t seed = 1;
  for (const cv::Size size : sizes) {
    const cv::Mat disparity = RandomScene(size, g, seed++);
    const cv::Rect regions[] = {
        cv::Rect(0, 0, size.width, size.height),
        cv::Rect(size.width / 3, size.height / 4, std::max(1, size.width / 2),
                 std::max(1, size.height / 2))};
    for (const cv::Rect& region : regions) {
      for (const double min_width_px : {0.0, 9.0}) {
        ThinStructureOptions options;
        options.min_width_px = min_width_px;
        for (const bool seeds_only : {false, true}) {
          const cv::Mat fast = BodyMask(disparity, g, region, options, seeds_only);
          const cv::Mat naive = testing::NaiveBodyMask(disparity, g, region, options, seeds_only);
          ASSERT_EQ(fast.size(), naive.size());
          EXPECT_EQ(cv::countNonZero(fast != naive), 0)
              << size << " region " << region << " min_width_px " << min_width_px << " seeds_only "
              << seeds_only << " (" << cv::countNonZero(naive) << " body pixels)";
        }
      }
    }
  }
}

// Bodies at a few depths and stray matches at every depth scattered over the view (what makes a
// depth band's bounding box most of the image): the clusters of a band's tiles are worked on
// apart, some near each other and near the bodies.
TEST(BodyMaskTest, EqualsTheWholeViewReferenceWithStrayMatches) {
  const StereoGeometry g = testing::TestGeometry();
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (const cv::Size size : {cv::Size(317, 241), cv::Size(160, 400)}) {
    cv::Mat disparity = RandomScene(size, g, 77);
    for (int i = 0; i < 900; ++i) {
      const int x = int(unit(rng) * size.width), y = int(unit(rng) * size.height);
      const int w = 1 + int(unit(rng) * 4), h = 1 + int(unit(rng) * 4);
      const cv::Rect r = cv::Rect(x, y, w, h) & cv::Rect(0, 0, size.width, size.height);
      // A third of them at the far end of the range: band 0, whose surface (bands -1..1 in the
      // naive loop) holds the pixels without a band too.
      const double z = i % 3 == 0 ? 7.4 + 0.6 * unit(rng) : 0.3 + 9.0 * unit(rng);
      disparity(r).setTo(g.DisparityFromDepth(z));
    }
    for (const double min_width_px : {0.0, 9.0}) {
      ThinStructureOptions options;
      options.min_width_px = min_width_px;
      for (const bool seeds_only : {false, true}) {
        const cv::Rect image(0, 0, size.width, size.height);
        const cv::Mat fast = BodyMask(disparity, g, image, options, seeds_only);
        const cv::Mat naive = testing::NaiveBodyMask(disparity, g, image, options, seeds_only);
        EXPECT_EQ(cv::countNonZero(fast != naive), 0)
            << size << " min_width_px " << min_width_px << " seeds_only " << seeds_only << " ("
            << cv::countNonZero(naive) << " body pixels)";
      }
    }
  }
}

// At the far end of the range: pixels without a disparity are no surface, so a speck among them
// is thin and a block a body; the valid pixels beyond the range are the farthest band's surface,
// so a speck on them is a body (the background continues there). Wherever the tiles' boundaries
// fall.
TEST(BodyMaskTest, AtTheFarEndOnlyTheBackgroundBeyondTheRangeIsSurface) {
  const StereoGeometry g = testing::TestGeometry();
  ThinStructureOptions options;
  const DepthBands bands(g, options.min_depth_m, options.max_depth_m, options.depth_band_relative);
  for (const int x0 : {13, 14, 15, 30, 31}) {
    cv::Mat disparity(cv::Size(97, 91), CV_32F, cv::Scalar(kInvalidDisparity));
    disparity(cv::Rect(0, 60, 97, 31)).setTo(0.5 * bands.d_low);  // beyond the range
    const cv::Rect speck(x0, 20, 2, 2), block(x0 + 40, 25, 20, 20), on_beyond(x0, 70, 2, 2);
    disparity(speck).setTo(bands.CentreDisparity(0));
    disparity(block).setTo(bands.CentreDisparity(0));
    disparity(on_beyond).setTo(bands.CentreDisparity(0));
    const cv::Rect image(0, 0, disparity.cols, disparity.rows);
    for (const bool seeds_only : {false, true}) {
      const cv::Mat fast = BodyMask(disparity, g, image, options, seeds_only);
      const cv::Mat naive = testing::NaiveBodyMask(disparity, g, image, options, seeds_only);
      EXPECT_EQ(cv::countNonZero(fast != naive), 0) << "x0 " << x0 << " seeds_only " << seeds_only;
      EXPECT_EQ(cv::countNonZero(fast(speck)), 0) << "x0 " << x0;
      EXPECT_GT(cv::countNonZero(fast(block)), 0) << "x0 " << x0;
      EXPECT_GT(cv::countNonZero(fast(on_beyond)), 0) << "x0 " << x0;
    }
  }
}

TEST(BodyMaskTest, EqualsTheWholeViewReferenceOnTheNeededPixels) {
  const StereoGeometry g = testing::TestGeometry();
  const cv::Size sizes[] = {{7, 300}, {257, 191}, {301, 203}};
  std::uint64_t seed = 21;
  for (const cv::Size size : sizes) {
    const cv::Mat disparity = RandomScene(size, g, seed++);
    const cv::Rect image(0, 0, size.width, size.height);
    // The used pixels: a slanted strip (like a corridor along a line) and a corner block.
    cv::Mat used(size, CV_8U, cv::Scalar(0));
    cv::line(used, {0, size.height / 3}, {size.width, 2 * size.height / 3}, cv::Scalar(255), 9);
    used(cv::Rect(0, 0, std::max(1, size.width / 5), std::max(1, size.height / 6))).setTo(255);
    int calls = 0;
    const BandRegion needed = [&](double d_from, double d_to) {
      ++calls;
      cv::Rect bounds;
      for (int y = 0; y < size.height; ++y) {
        for (int x = 0; x < size.width; ++x) {
          const float d = disparity.at<float>(y, x);
          if (used.at<std::uint8_t>(y, x) && IsValidDisparity(d) && d >= d_from && d <= d_to) {
            bounds |= cv::Rect(x, y, 1, 1);
          }
        }
      }
      return bounds;
    };
    for (const double min_width_px : {0.0, 9.0}) {
      ThinStructureOptions options;
      options.min_width_px = min_width_px;
      const cv::Mat fast = BodyMask(disparity, g, image, options, false, needed);
      const cv::Mat naive = testing::NaiveBodyMask(disparity, g, image, options, false);
      EXPECT_GT(calls, 0);
      EXPECT_EQ(cv::countNonZero((fast != naive) & used), 0)
          << size << " min_width_px " << min_width_px << " (" << cv::countNonZero(naive & used)
          << " body pixels used)";
    }
  }
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
