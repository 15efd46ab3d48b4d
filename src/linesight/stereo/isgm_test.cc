#include "linesight/stereo/isgm.h"

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "linesight/core/disparity.h"
#include "linesight/core/error.h"

namespace linesight {
namespace {

// A textured pair: left half of the scene at disparity 9, right half a slanted plane d = 14 + 0.02
// * y.
void MakeTwoSurfacePair(int width, int height, cv::Mat* left, cv::Mat* right, cv::Mat* truth) {
  cv::RNG rng(7);
  cv::Mat texture(height, width + 64, CV_8UC3);
  rng.fill(texture, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(texture, texture, cv::Size(5, 5), 1.2);
  *left = cv::Mat(height, width, CV_8UC3);
  *right = cv::Mat(height, width, CV_8UC3, cv::Scalar(0, 0, 0));
  *truth = cv::Mat(height, width, CV_32FC1);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const float d = x < width / 2 ? 9.0f : 14.0f + 0.02f * y;
      truth->at<float>(y, x) = d;
      left->at<cv::Vec3b>(y, x) = texture.at<cv::Vec3b>(y, x + 32);
    }
  }
  // Right view: every right pixel shows the nearest surface point that projects onto it.
  cv::Mat best(height, width, CV_32FC1, cv::Scalar(-1.0f));
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const float d = truth->at<float>(y, x);
      const int xr = static_cast<int>(std::lround(x - d));
      if (xr < 0 || xr >= width || d <= best.at<float>(y, xr)) continue;
      best.at<float>(y, xr) = d;
      right->at<cv::Vec3b>(y, xr) = left->at<cv::Vec3b>(y, x);
    }
  }
}

TEST(IsgmOptions, DefaultsAreValid) {
  EXPECT_NO_THROW(IsgmOptions().Check());
  EXPECT_EQ(IsgmOptions().sgm.p2_gradient_alpha, IsgmDefaultSgmOptions().p2_gradient_alpha);
  EXPECT_EQ(IsgmOptions().refinement.inlier_threshold,
            IsgmDefaultRefinementOptions().inlier_threshold);
  EXPECT_NO_THROW(IsgmDefaultSgmOptions().Check());
  EXPECT_NO_THROW(IsgmDefaultRefinementOptions().Check());
}

TEST(IsgmOptions, InvalidPartsAreNamed) {
  IsgmOptions o;
  o.refinement.outlier_threshold = o.refinement.inlier_threshold / 2;  // below the inlier band
  EXPECT_THROW(o.Check(), OptionError);
  o = IsgmOptions();
  o.sgm.p2 = o.sgm.p1;
  EXPECT_THROW(o.Check(), OptionError);
}

TEST(CreateMatcherIsgm, ParamsReachTheOptions) {
  MatcherOptions mo;
  mo.num_disparities = 37;
  mo.params = {{"superpixel_size", "16"}, {"plane_inlier", "0.8"}, {"p1", "9"}, {"p2", "99"}};
  auto matcher = CreateMatcher("isgm", mo);
  ASSERT_EQ(matcher->Name(), "isgm");
  const nlohmann::json settings = matcher->Settings();
  EXPECT_EQ(settings["refinement"]["superpixel_size"], 16);
  EXPECT_EQ(settings["refinement"]["inlier_threshold"], 0.8);
  EXPECT_EQ(settings["sgm"]["p1"], 9);
  EXPECT_EQ(settings["sgm"]["p2"], 99);
  // Untouched keys keep isgm's tuned defaults.
  EXPECT_EQ(settings["sgm"]["p2_alpha"], IsgmDefaultSgmOptions().p2_gradient_alpha);
  EXPECT_EQ(settings["sgm"]["census_width"], IsgmDefaultSgmOptions().census_width);
  EXPECT_EQ(settings["sgm"]["census_height"], IsgmDefaultSgmOptions().census_height);
  EXPECT_EQ(settings["refinement"]["outlier_threshold"],
            IsgmDefaultRefinementOptions().outlier_threshold);
  EXPECT_EQ(settings["refinement"]["superpixel_compactness"],
            IsgmDefaultRefinementOptions().superpixels.compactness);
  // A census window given explicitly wins over isgm's default.
  mo.params = {{"census_width", "9"}, {"census_height", "7"}};
  const nlohmann::json nine = CreateMatcher("isgm", mo)->Settings();
  EXPECT_EQ(nine["sgm"]["census_width"], 9);
  EXPECT_EQ(nine["sgm"]["census_height"], 7);
}

TEST(CreateMatcherIsgm, BadParamsAreRejected) {
  MatcherOptions mo;
  mo.params = {{"superpixel_size", "3"}};
  EXPECT_THROW(CreateMatcher("isgm", mo), OptionError);
  mo.params = {{"superpixel_sise", "12"}};
  EXPECT_THROW(CreateMatcher("isgm", mo), UsageError);
}

TEST(IsgmMatcher, DenseAccurateWithinRangeAndThreadIndependent) {
  cv::Mat left, right, truth;
  MakeTwoSurfacePair(161, 97, &left, &right, &truth);
  MatcherOptions mo;
  mo.num_disparities = 23;  // awkward range: 0..22
  mo.threads = 1;
  const cv::Mat one = CreateMatcher("isgm", mo)->Compute(left, right).disparity;
  mo.threads = 2;
  const cv::Mat two = CreateMatcher("isgm", mo)->Compute(left, right).disparity;
  ASSERT_EQ(one.type(), CV_32FC1);
  EXPECT_EQ(std::memcmp(one.data, two.data, one.total() * sizeof(float)), 0);
  int bad = 0, evaluated = 0, bad_inside = 0, inside = 0;
  for (int y = 0; y < one.rows; ++y) {
    for (int x = 0; x < one.cols; ++x) {
      const float d = one.at<float>(y, x);
      ASSERT_TRUE(IsValidDisparity(d)) << x << "," << y;
      ASSERT_GE(d, 0.0f);
      ASSERT_LE(d, 22.0f);
      if (x < 24) continue;  // the left border sees nothing in the right image
      const bool is_bad = std::abs(d - truth.at<float>(y, x)) > 1.0f;
      ++evaluated;
      bad += is_bad;
      // Away from the depth edge at x = 80 (and its occlusion) the surfaces are recovered.
      if (std::abs(x - one.cols / 2) > 8 && y > 4 && y < one.rows - 5) {
        ++inside;
        bad_inside += is_bad;
      }
    }
  }
  EXPECT_LT(bad, evaluated / 20) << bad << " of " << evaluated;
  EXPECT_LT(bad_inside, inside / 100) << bad_inside << " of " << inside;
}

// Dense bad-1.0 on the non-occluded pixels of Middlebury tsukuba (measured 3.30 % at commit time;
// the published SGM figure is 3.26 %).
TEST(IsgmMatcher, TsukubaDenseBad1Nonocc) {
  const std::filesystem::path dir =
      std::filesystem::path(LINESIGHT_SHARED_DATA_DIR) / "middlebury-2001-2003" / "tsukuba";
  if (!std::filesystem::exists(dir / "imL.png")) {
    GTEST_SKIP() << "no Middlebury tsukuba under " << dir << " (../shared/data is optional)";
  }
  const cv::Mat left = cv::imread((dir / "imL.png").string(), cv::IMREAD_COLOR);
  const cv::Mat right = cv::imread((dir / "imR.png").string(), cv::IMREAD_COLOR);
  const cv::Mat gt = cv::imread((dir / "groundtruth.png").string(), cv::IMREAD_GRAYSCALE);
  const cv::Mat nonocc = cv::imread((dir / "nonocc.png").string(), cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(left.empty() || right.empty() || gt.empty() || nonocc.empty());
  std::ifstream info(dir / "info.txt");
  double scale = 16;
  int ndisp = 16;
  info >> scale >> ndisp;
  MatcherOptions mo;
  mo.num_disparities = ndisp;
  const cv::Mat d = CreateMatcher("isgm", mo)->Compute(left, right).disparity;
  int evaluated = 0, bad = 0;
  for (int y = 0; y < d.rows; ++y) {
    for (int x = 0; x < d.cols; ++x) {
      ASSERT_TRUE(IsValidDisparity(d.at<float>(y, x)));
      if (nonocc.at<uint8_t>(y, x) != 255 || gt.at<uint8_t>(y, x) == 0) continue;
      ++evaluated;
      bad += std::abs(d.at<float>(y, x) - gt.at<uint8_t>(y, x) / scale) > 1.0;
    }
  }
  ASSERT_GT(evaluated, 80000);
  const double bad_percent = 100.0 * bad / evaluated;
  RecordProperty("bad1_nonocc_percent", std::to_string(bad_percent));
  EXPECT_LT(bad_percent, 4.0);
}

}  // namespace
}  // namespace linesight

namespace linesight {
namespace {

// Compute() reuses its internal buffers between frames: an earlier returned map must stay intact.
TEST(IsgmMatcher, ComputeReturnsAFreshMapEveryFrame) {
  cv::Mat left_a, right_a, truth_a, left_b, right_b, truth_b;
  MakeTwoSurfacePair(120, 80, &left_a, &right_a, &truth_a);
  MakeTwoSurfacePair(120, 80, &left_b, &right_b, &truth_b);
  cv::flip(left_b, left_b, 0);
  cv::flip(right_b, right_b, 0);
  IsgmOptions o;
  o.sgm.num_disparities = 24;
  IsgmMatcher isgm(o);
  SgmMatcher sgm(o.sgm);
  const cv::Mat isgm_a = isgm.Compute(left_a, right_a).disparity,
                sgm_a = sgm.Compute(left_a, right_a).disparity;
  const cv::Mat isgm_a_copy = isgm_a.clone(), sgm_a_copy = sgm_a.clone();
  const cv::Mat isgm_b = isgm.Compute(left_b, right_b).disparity,
                sgm_b = sgm.Compute(left_b, right_b).disparity;
  EXPECT_NE(isgm_a.data, isgm_b.data);
  EXPECT_NE(sgm_a.data, sgm_b.data);
  EXPECT_EQ(cv::norm(isgm_a, isgm_a_copy, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::countNonZero(sgm_a != sgm_a_copy), 0);
  // The frames differ, and the reused buffers give what a fresh matcher gives.
  EXPECT_GT(cv::countNonZero(sgm_a != sgm_b), 0);
  EXPECT_EQ(cv::norm(isgm_b, IsgmMatcher(o).Compute(left_b, right_b).disparity, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::countNonZero(sgm_b != SgmMatcher(o.sgm).Compute(left_b, right_b).disparity), 0);
}

}  // namespace
}  // namespace linesight
