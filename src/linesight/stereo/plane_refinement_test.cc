#include "linesight/stereo/plane_refinement.h"

#include <filesystem>
#include <fstream>

#include <limits>

#include <gtest/gtest.h>
#include <hwy/tests/hwy_gtest.h>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "linesight/core/disparity.h"
#include "linesight/core/error.h"

namespace linesight {
namespace {

using detail::DisparityPlane;
using detail::PlanePoint;

cv::Mat TexturedImage(int width, int height, uint64_t seed) {
  cv::RNG rng(seed);
  cv::Mat image(height, width, CV_8UC3);
  rng.fill(image, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(image, image, cv::Size(9, 9), 3.0);
  return image;
}

cv::Mat PlaneDisparity(int width, int height, const DisparityPlane& plane) {
  cv::Mat d(height, width, CV_32FC1);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) d.at<float>(y, x) = static_cast<float>(plane.At(x, y));
  }
  return d;
}

int CountInvalid(const cv::Mat& d) {
  int n = 0;
  for (int y = 0; y < d.rows; ++y) {
    for (int x = 0; x < d.cols; ++x) n += !IsValidDisparity(d.at<float>(y, x));
  }
  return n;
}

TEST(PlaneRefinementOptions, DefaultsAreValid) {
  EXPECT_NO_THROW(PlaneRefinementOptions().Check());
}

TEST(PlaneRefinementOptions, Boundaries) {
  PlaneRefinementOptions o;
  o.outlier_threshold = o.inlier_threshold;
  EXPECT_NO_THROW(o.Check());
  o.outlier_threshold = o.inlier_threshold - 0.01;
  EXPECT_THROW(o.Check(), OptionError);
  o = PlaneRefinementOptions();
  o.inlier_threshold = 0;
  EXPECT_THROW(o.Check(), OptionError);
  o = PlaneRefinementOptions();
  o.min_support = 2;
  EXPECT_THROW(o.Check(), OptionError);
  o.min_support = 3;
  EXPECT_NO_THROW(o.Check());
  o = PlaneRefinementOptions();
  o.min_inlier_ratio = 0;
  EXPECT_THROW(o.Check(), OptionError);
  o.min_inlier_ratio = 1;
  EXPECT_NO_THROW(o.Check());
  o = PlaneRefinementOptions();
  o.min_support_ratio = 1.5;
  EXPECT_THROW(o.Check(), OptionError);
  o = PlaneRefinementOptions();
  o.max_slant = 0;
  EXPECT_THROW(o.Check(), OptionError);
  o = PlaneRefinementOptions();
  o.ransac_iterations = -1;
  EXPECT_THROW(o.Check(), OptionError);
  o = PlaneRefinementOptions();
  o.ransac_max_points = 7;
  EXPECT_THROW(o.Check(), OptionError);
  o = PlaneRefinementOptions();
  o.refit_iterations = 0;
  EXPECT_THROW(o.Check(), OptionError);
  o = PlaneRefinementOptions();
  o.median_size = 2;
  EXPECT_THROW(o.Check(), OptionError);
  o.median_size = 0;
  EXPECT_NO_THROW(o.Check());
  o = PlaneRefinementOptions();
  o.max_residual_rms = 0;
  EXPECT_THROW(o.Check(), OptionError);
  o = PlaneRefinementOptions();
  o.superpixels.region_size = 2;
  try {
    o.Check();
    FAIL();
  } catch (const OptionError& e) {
    EXPECT_STREQ(e.what(), "SuperpixelOptions.region_size = 2: must be >= 4");
  }
}

TEST(AccumulateNormalEquations, EqualsNaiveSumsOnAwkwardSets) {
  cv::RNG rng(5);
  for (int n : {1, 3, 7, 37, 311}) {
    std::vector<PlanePoint> points(n);
    std::vector<uint8_t> selected(n);
    for (int i = 0; i < n; ++i) {
      points[i] = {static_cast<float>(rng.uniform(0, 311)), static_cast<float>(rng.uniform(0, 239)),
                   rng.uniform(0.0f, 64.0f)};
      selected[i] = rng.uniform(0, 3) != 0;
    }
    const double ox = 101.5, oy = 77.25;
    const auto eq = detail::AccumulateNormalEquations(points, &selected, ox, oy);
    // Naive: M = A^T A and r = A^T d with rows [x - ox, y - oy, 1] of the selected points.
    double m[3][3] = {}, r[3] = {};
    for (int i = 0; i < n; ++i) {
      if (!selected[i]) continue;
      const double row[3] = {points[i].x - ox, points[i].y - oy, 1.0};
      for (int a = 0; a < 3; ++a) {
        for (int b = 0; b < 3; ++b) m[a][b] += row[a] * row[b];
        r[a] += row[a] * points[i].d;
      }
    }
    EXPECT_EQ(eq.sxx, m[0][0]);
    EXPECT_EQ(eq.sxy, m[0][1]);
    EXPECT_EQ(eq.sx, m[0][2]);
    EXPECT_EQ(eq.syy, m[1][1]);
    EXPECT_EQ(eq.sy, m[1][2]);
    EXPECT_EQ(eq.n, m[2][2]);
    EXPECT_EQ(eq.sxd, r[0]);
    EXPECT_EQ(eq.syd, r[1]);
    EXPECT_EQ(eq.sd, r[2]);
  }
}

TEST(SolvePlane, RecoversKnownPlaneFromCleanData) {
  const DisparityPlane truth{0.125, -0.0625, 20.5};
  std::vector<PlanePoint> points;
  for (int y = 40; y < 52; ++y) {
    for (int x = 100; x < 113; ++x) points.push_back({float(x), float(y), float(truth.At(x, y))});
  }
  const auto eq = detail::AccumulateNormalEquations(points, nullptr, 106, 45.5);
  DisparityPlane plane;
  ASSERT_TRUE(detail::SolvePlane(eq, 106, 45.5, &plane));
  EXPECT_NEAR(plane.a, truth.a, 1e-9);
  EXPECT_NEAR(plane.b, truth.b, 1e-9);
  EXPECT_NEAR(plane.c, truth.c, 1e-7);
}

TEST(SolvePlane, RejectsCollinearAndTooFewPoints) {
  std::vector<PlanePoint> line;
  for (int i = 0; i < 10; ++i) line.push_back({float(i), float(2 * i), 3.0f});
  DisparityPlane plane;
  EXPECT_FALSE(
      detail::SolvePlane(detail::AccumulateNormalEquations(line, nullptr, 5, 10), 5, 10, &plane));
  line.resize(2);
  EXPECT_FALSE(
      detail::SolvePlane(detail::AccumulateNormalEquations(line, nullptr, 0, 0), 0, 0, &plane));
}

class PlaneKernelTest : public hwy::TestWithParamTarget {};
HWY_TARGET_INSTANTIATE_TEST_SUITE_P(PlaneKernelTest);

TEST_P(PlaneKernelTest, InlierCountEqualsScalarForm) {
  cv::RNG rng(11);
  for (const int n : {0, 1, 7, 16, 37, 48, 161}) {
    const size_t padded = (static_cast<size_t>(n) + detail::kPlanePointPadding - 1) /
                          detail::kPlanePointPadding * detail::kPlanePointPadding;
    std::vector<double> x(padded, 0.0), y(padded, 0.0),
        d(padded, std::numeric_limits<double>::quiet_NaN());
    const detail::DisparityPlane plane{0.031, -0.017, 21.5};
    for (int i = 0; i < n; ++i) {
      x[i] = rng.uniform(0, 752);
      y[i] = rng.uniform(0, 480);
      // Residuals around the threshold, some exactly on it (integer plane values).
      d[i] = i % 5 == 0 ? 21.5 + 0.031 * x[i] - 0.017 * y[i] - 0.5
                        : plane.At(x[i], y[i]) + rng.uniform(-1.5, 1.5);
    }
    for (const double threshold : {0.25, 0.5, 1.0}) {
      int expected = 0;
      for (int i = 0; i < n; ++i) expected += std::abs(plane.At(x[i], y[i]) - d[i]) <= threshold;
      EXPECT_EQ(detail::CountPlaneInliers(x.data(), y.data(), d.data(), padded, plane, threshold),
                expected)
          << "n " << n << " threshold " << threshold;
    }
  }
}

TEST(FitPlaneRobust, IgnoresThirtyPercentOutliers) {
  const DisparityPlane truth{-0.2, 0.15, 35.0};
  cv::RNG rng(17);
  std::vector<PlanePoint> points;
  int outliers = 0;
  for (int y = 0; y < 14; ++y) {
    for (int x = 0; x < 14; ++x) {
      float d = static_cast<float>(truth.At(x + 200, y + 60));
      if (rng.uniform(0.0, 1.0) < 0.3) {
        d += rng.uniform(3.0f, 25.0f) * (rng.uniform(0, 2) ? 1.0f : -1.0f);  // a gross mismatch
        ++outliers;
      }
      points.push_back({float(x + 200), float(y + 60), d});
    }
  }
  ASSERT_GT(outliers, 196 / 4);
  detail::RobustPlaneFit fit;
  ASSERT_TRUE(detail::FitPlaneRobust(points, PlaneRefinementOptions(), 1, &fit));
  EXPECT_NEAR(fit.plane.a, truth.a, 1e-5);
  EXPECT_NEAR(fit.plane.b, truth.b, 1e-5);
  EXPECT_NEAR(fit.plane.At(207, 67), truth.At(207, 67), 1e-4);
  EXPECT_EQ(fit.inliers, 196 - outliers);
  EXPECT_LT(fit.residual_rms, 1e-4);

  // A plain least-squares fit of the same points is pulled far away: the test can tell the two
  // apart.
  DisparityPlane plain;
  ASSERT_TRUE(
      detail::SolvePlane(detail::AccumulateNormalEquations(points, nullptr, 0, 0), 0, 0, &plain));
  EXPECT_GT(std::abs(plain.At(207, 67) - truth.At(207, 67)) + std::abs(plain.a - truth.a) * 14,
            0.1);
}

TEST(RefineDisparityWithPlanes, FillsHolesInASlantedPlaneWithPlaneValues) {
  const DisparityPlane truth{0.05, 0.08, 12.0};
  const int width = 157, height = 111;
  const cv::Mat image = TexturedImage(width, height, 2);
  const cv::Mat exact = PlaneDisparity(width, height, truth);
  cv::Mat holes = exact.clone();
  cv::RNG rng(9);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      if (rng.uniform(0.0, 1.0) < 0.25) holes.at<float>(y, x) = kInvalidDisparity;
    }
  }
  holes(cv::Rect(60, 40, 9, 7)).setTo(kInvalidDisparity);  // a block hole as well
  // Values are clamped to the input's range: keep the plane's extremes (two corners) valid.
  holes.at<float>(0, 0) = exact.at<float>(0, 0);
  holes.at<float>(height - 1, width - 1) = exact.at<float>(height - 1, width - 1);
  PlaneRefinementStats stats;
  PlaneRefinementOptions options;
  options.median_size = 0;  // exact plane values (the final median rounds off the image border)
  const cv::Mat out = RefineDisparityWithPlanes(holes, image, options, &stats);
  EXPECT_EQ(CountInvalid(out), 0);
  EXPECT_GT(stats.holes_filled_by_plane, width * height / 5);
  double worst = 0;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      worst = std::max(worst, double(std::abs(out.at<float>(y, x) - exact.at<float>(y, x))));
    }
  }
  EXPECT_LT(worst, 1e-3);
}

TEST(RefineDisparityWithPlanes, ReplacesMismatchesByThePlane) {
  const DisparityPlane truth{-0.03, 0.02, 30.0};
  const cv::Mat image = TexturedImage(120, 90, 4);
  const cv::Mat exact = PlaneDisparity(120, 90, truth);
  cv::Mat noisy = exact.clone();
  cv::RNG rng(21);
  for (int i = 0; i < 900; ++i) noisy.at<float>(rng.uniform(0, 90), rng.uniform(0, 120)) += 9.0f;
  PlaneRefinementStats stats;
  PlaneRefinementOptions options;
  options.median_size = 0;  // exact plane values (the final median rounds off the image border)
  const cv::Mat out = RefineDisparityWithPlanes(noisy, image, options, &stats);
  EXPECT_GT(stats.outliers_replaced, 800);
  EXPECT_LT(cv::norm(out, exact, cv::NORM_INF), 1e-3);
}

TEST(RefineDisparityWithPlanes, DoesNotFlattenASegmentStraddlingADepthEdge) {
  // A flat-coloured image gives grid-like superpixels, so segments straddle the depth edge at x
  // = 53.
  const int width = 120, height = 96;
  const cv::Mat image(height, width, CV_8UC3, cv::Scalar(90, 90, 90));
  cv::Mat d(height, width, CV_32FC1, cv::Scalar(10.0f));
  d.colRange(53, width).setTo(25.0f);
  PlaneRefinementStats stats;
  const cv::Mat out = RefineDisparityWithPlanes(d, image, PlaneRefinementOptions(), &stats);
  EXPECT_GT(stats.two_plane_segments, 0);
  EXPECT_EQ(stats.outliers_replaced, 0);
  EXPECT_EQ(cv::norm(out, d, cv::NORM_INF), 0.0);
}

TEST(BuildSegmentIndex, EqualsNaiveRasterOrderOnAwkwardSizes) {
  cv::RNG rng(3);
  for (const cv::Size size : {cv::Size(311, 239), cv::Size(1, 1), cv::Size(5, 3), cv::Size(2, 9)}) {
    const int segments = 1 + size.area() / 40;
    cv::Mat labels(size, CV_32SC1);
    for (int y = 0; y < size.height; ++y) {
      for (int x = 0; x < size.width; ++x) {
        // Mostly blocks (as superpixels), some scattered labels, one segment left empty.
        const int block = (y / 7) * ((size.width + 6) / 7) + x / 7;
        labels.at<int32_t>(y, x) =
            rng.uniform(0, 10) == 0 ? rng.uniform(0, segments) : block % segments;
      }
    }
    const detail::SegmentIndex index = detail::BuildSegmentIndex(labels, segments + 1);
    ASSERT_EQ(index.offsets.size(), static_cast<size_t>(segments + 2));
    EXPECT_EQ(index.Size(segments), 0);
    std::vector<int32_t> expected;
    for (int s = 0; s <= segments; ++s) {
      ASSERT_EQ(index.offsets[s], static_cast<int32_t>(expected.size())) << s;
      for (int p = 0; p < size.area(); ++p) {
        if (labels.at<int32_t>(p / size.width, p % size.width) == s) expected.push_back(p);
      }
    }
    ASSERT_EQ(index.pixels, expected);
    for (size_t i = 0; i < expected.size(); ++i) {
      ASSERT_EQ(index.x[i], expected[i] % size.width);
      ASSERT_EQ(index.y[i], expected[i] / size.width);
    }
  }
}

TEST(MedianBlurStripes, EqualsOpenCvMedianForAnyThreadCount) {
  const int saved_threads = cv::getNumThreads();
  cv::RNG rng(7);
  for (const cv::Size size :
       {cv::Size(311, 239), cv::Size(17, 97), cv::Size(64, 41), cv::Size(5, 3)}) {
    cv::Mat src(size, CV_32FC1);
    rng.fill(src, cv::RNG::UNIFORM, -5.0, 80.0);
    // Runs of equal values and unknown (+inf) pixels, as in a filled disparity map.
    src.rowRange(0, std::min(3, size.height)).setTo(12.5f);
    for (int i = 0; i < size.area() / 20; ++i) {
      src.at<float>(rng.uniform(0, size.height), rng.uniform(0, size.width)) =
          std::numeric_limits<float>::infinity();
    }
    for (const int ksize : {3, 5}) {
      cv::Mat expected;
      cv::medianBlur(src, expected, ksize);
      for (const int threads : {1, 2, 3, 8}) {
        cv::setNumThreads(threads);
        const cv::Mat got = detail::MedianBlurStripes(src, ksize);
        ASSERT_EQ(got.size(), expected.size());
        ASSERT_EQ(got.type(), expected.type());
        EXPECT_EQ(cv::norm(got != expected, cv::NORM_L1), 0.0)
            << size << " ksize " << ksize << " threads " << threads;
      }
    }
  }
  cv::setNumThreads(saved_threads);
}

TEST(RefineDisparityWithPlanes, OcclusionTakesTheBackground) {
  // Foreground square (d = 30) on a background (d = 8); the band left of the square (its occlusion
  // in the left view) is invalid and lies in flat-coloured segments without own support.
  const int width = 140, height = 100;
  cv::Mat image(height, width, CV_8UC3, cv::Scalar(60, 60, 60));
  cv::Mat d(height, width, CV_32FC1, cv::Scalar(8.0f));
  d(cv::Rect(70, 30, 40, 40)).setTo(30.0f);
  image(cv::Rect(70, 30, 40, 40)).setTo(cv::Scalar(200, 200, 200));
  d(cv::Rect(48, 30, 22, 40)).setTo(kInvalidDisparity);
  const cv::Mat out = RefineDisparityWithPlanes(d, image, PlaneRefinementOptions());
  EXPECT_EQ(CountInvalid(out), 0);
  for (int y = 30; y < 70; ++y) {
    for (int x = 48; x < 70; ++x) ASSERT_FLOAT_EQ(out.at<float>(y, x), 8.0f) << x << "," << y;
  }
  EXPECT_FLOAT_EQ(out.at<float>(50, 90), 30.0f);
}

TEST(RefineDisparityWithPlanes, AllInvalidBecomesZeroAndShapesAreChecked) {
  const cv::Mat image = TexturedImage(31, 17, 1);
  const cv::Mat d(17, 31, CV_32FC1, cv::Scalar(kInvalidDisparity));
  const cv::Mat out = RefineDisparityWithPlanes(d, image, PlaneRefinementOptions());
  EXPECT_EQ(cv::countNonZero(out), 0);
  EXPECT_THROW(RefineDisparityWithPlanes(d, TexturedImage(30, 17, 1), PlaneRefinementOptions()),
               InputError);
  EXPECT_THROW(
      RefineDisparityWithPlanes(cv::Mat(17, 31, CV_16SC1), image, PlaneRefinementOptions()),
      InputError);
}

// A scene of two slanted planes with mismatches and holes, like a real matcher's output.
cv::Mat NoisyTwoPlaneDisparity(int width, int height, uint64_t seed) {
  cv::Mat d(height, width, CV_32FC1);
  cv::RNG rng(seed);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      float v = x < width / 2 ? 10.0f + 0.03f * x : 25.0f - 0.02f * y;
      const double u = rng.uniform(0.0, 1.0);
      if (u < 0.15)
        v = kInvalidDisparity;
      else if (u < 0.25)
        v += rng.uniform(-8.0f, 8.0f);
      else
        v += rng.uniform(-0.3f, 0.3f);
      d.at<float>(y, x) = v;
    }
  }
  return d;
}

TEST(RefineDisparityWithPlanes, DenseDeterministicAndThreadIndependent) {
  const int width = 311, height = 239;
  const cv::Mat image = TexturedImage(width, height, 8);
  const cv::Mat d = NoisyTwoPlaneDisparity(width, height, 3);
  const int saved = cv::getNumThreads();
  cv::setNumThreads(1);
  const cv::Mat one = RefineDisparityWithPlanes(d, image, PlaneRefinementOptions());
  cv::setNumThreads(3);
  const cv::Mat three = RefineDisparityWithPlanes(d, image, PlaneRefinementOptions());
  const cv::Mat again = RefineDisparityWithPlanes(d, image, PlaneRefinementOptions());
  cv::setNumThreads(saved);
  EXPECT_EQ(CountInvalid(one), 0);
  EXPECT_EQ(std::memcmp(one.data, three.data, one.total() * sizeof(float)), 0);
  EXPECT_EQ(std::memcmp(one.data, again.data, one.total() * sizeof(float)), 0);
  // And it is better than the input: mismatches (farther than the outlier threshold) become plane
  // values.
  const float tolerance = static_cast<float>(PlaneRefinementOptions().outlier_threshold);
  int bad_in = 0, bad_out = 0;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const float truth = x < width / 2 ? 10.0f + 0.03f * x : 25.0f - 0.02f * y;
      const float in = d.at<float>(y, x);
      bad_in += !IsValidDisparity(in) || std::abs(in - truth) > tolerance;
      bad_out += std::abs(one.at<float>(y, x) - truth) > tolerance;
    }
  }
  EXPECT_GT(bad_in, width * height / 5);
  EXPECT_LT(bad_out, width * height / 100);
}

}  // namespace
}  // namespace linesight
