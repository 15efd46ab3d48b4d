#include "linesight/rectify/rectifier.h"

#include <random>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "linesight/core/error.h"

namespace linesight {
namespace {

// A rig like the MYNT S1030: 752x480, f ~ 736 px, B ~ 0.119 m, plumb-bob distortion, slightly
// misaligned.
StereoCalibration SyntheticRig() {
  StereoCalibration c;
  c.image_size = {752, 480};
  c.M1 = (cv::Mat_<double>(3, 3) << 736.0, 0, 381.5, 0, 737.2, 236.0, 0, 0, 1);
  c.M2 = (cv::Mat_<double>(3, 3) << 738.5, 0, 369.0, 0, 739.0, 243.5, 0, 0, 1);
  c.D1 = (cv::Mat_<double>(1, 5) << -0.29, 0.085, 0.0006, -0.0004, 0.0);
  c.D2 = (cv::Mat_<double>(1, 5) << -0.28, 0.080, -0.0005, 0.0003, 0.0);
  cv::Mat rvec = (cv::Mat_<double>(3, 1) << 0.006, -0.009, 0.004);
  cv::Rodrigues(rvec, c.R);
  cv::Mat baseline_in_left = (cv::Mat_<double>(3, 1) << 0.119, 0.0015, -0.001);
  c.T = -c.R * baseline_in_left;  // right_from_left: the right centre sits at +x in the left frame
  return c;
}

struct Correspondences {
  std::vector<cv::Point3d> points_left;  // 3D, left camera frame
  std::vector<cv::Point2f> left_raw, right_raw;
};

Correspondences ProjectRandomPoints(const StereoCalibration& c, int count, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ux(-0.45, 0.45), uy(-0.3, 0.3), uz(0.4, 6.0);
  Correspondences out;
  cv::Mat rvec;
  cv::Rodrigues(c.R, rvec);
  while (static_cast<int>(out.points_left.size()) < count) {
    const double z = uz(rng);
    cv::Point3d p(ux(rng) * z, uy(rng) * z, z);
    std::vector<cv::Point2d> l, r;
    cv::projectPoints(std::vector<cv::Point3d>{p}, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), c.M1,
                      c.D1, l);
    cv::projectPoints(std::vector<cv::Point3d>{p}, rvec, c.T, c.M2, c.D2, r);
    const cv::Rect inside(20, 20, c.image_size.width - 40, c.image_size.height - 40);
    if (!inside.contains(cv::Point2f(l[0])) || !inside.contains(cv::Point2f(r[0]))) continue;
    out.points_left.push_back(p);
    out.left_raw.push_back(cv::Point2f(l[0]));
    out.right_raw.push_back(cv::Point2f(r[0]));
  }
  return out;
}

float Bilinear(const cv::Mat& m, cv::Point2f p) {
  cv::Mat patch;
  cv::getRectSubPix(m, {1, 1}, p, patch, CV_32F);
  return patch.at<float>(0, 0);
}

TEST(RectifyOptionsTest, DefaultsAreValid) { EXPECT_NO_THROW(RectifyOptions{}.Check()); }

TEST(RectifyOptionsTest, RejectsAlphaOutOfRange) {
  RectifyOptions o;
  o.alpha = 1.5;
  EXPECT_THROW(o.Check(), OptionError);
  o.alpha = -0.5;
  EXPECT_THROW(o.Check(), OptionError);
  o.alpha = -1.0;
  EXPECT_NO_THROW(o.Check());
  o.alpha = 1.0;
  EXPECT_NO_THROW(o.Check());
  o.interpolation = 7;
  EXPECT_THROW(o.Check(), OptionError);
}

TEST(RectifierTest, CorrespondingPointsShareARowAndGiveTheTrueDisparity) {
  const StereoCalibration rig = SyntheticRig();
  const Rectifier rectifier(rig);
  const Correspondences pts = ProjectRandomPoints(rig, 300, 7);
  const auto left = rectifier.RectifyLeftPoints(pts.left_raw);
  const auto right = rectifier.RectifyRightPoints(pts.right_raw);
  const StereoCalibration& rc = rectifier.calibration();
  const double f = rc.P1.at<double>(0, 0);
  const double baseline = -rc.P2.at<double>(0, 3) / rc.P2.at<double>(0, 0);
  EXPECT_NEAR(baseline, 0.119 * std::sqrt(1 + (0.0015 * 0.0015 + 0.001 * 0.001) / (0.119 * 0.119)),
              1e-9);
  double worst_dy = 0.0, worst_disparity_error = 0.0;
  for (size_t i = 0; i < left.size(); ++i) {
    worst_dy = std::max(worst_dy, std::abs(double(left[i].y - right[i].y)));
    cv::Mat x = rc.R1 * cv::Mat(cv::Vec3d(pts.points_left[i].x, pts.points_left[i].y,
                                          pts.points_left[i].z));
    const double expected = f * baseline / x.at<double>(2);
    worst_disparity_error =
        std::max(worst_disparity_error, std::abs(left[i].x - right[i].x - expected));
  }
  EXPECT_LT(worst_dy, 0.05);
  EXPECT_LT(worst_disparity_error, 0.05);
}

TEST(RectifierTest, RemapTablesPointBackToTheRawPixels) {
  const StereoCalibration rig = SyntheticRig();
  const Rectifier rectifier(rig);
  const Correspondences pts = ProjectRandomPoints(rig, 200, 11);
  const auto left = rectifier.RectifyLeftPoints(pts.left_raw);
  double worst = 0.0;
  int checked = 0;
  for (size_t i = 0; i < left.size(); ++i) {
    if (!cv::Rect(2, 2, rig.image_size.width - 4, rig.image_size.height - 4).contains(left[i]))
      continue;
    const cv::Point2f back(Bilinear(rectifier.left_map_x(), left[i]),
                           Bilinear(rectifier.left_map_y(), left[i]));
    worst = std::max(worst, cv::norm(back - pts.left_raw[i]));
    ++checked;
  }
  EXPECT_GT(checked, 150);
  EXPECT_LT(worst, 0.05);
}

// Renders Gaussian dots at the raw projections, rectifies the images and checks the dots'
// centroids.
TEST(RectifierTest, RectifiedImagesPutCorrespondingDotsOnTheSameRow) {
  const StereoCalibration rig = SyntheticRig();
  const Rectifier rectifier(rig);
  Correspondences pts = ProjectRandomPoints(rig, 40, 3);
  auto render = [&](const std::vector<cv::Point2f>& centres) {
    cv::Mat image(rig.image_size, CV_32F, cv::Scalar(0));
    for (const cv::Point2f& c : centres) {
      for (int y = int(c.y) - 8; y <= int(c.y) + 8; ++y) {
        for (int x = int(c.x) - 8; x <= int(c.x) + 8; ++x) {
          const double r2 = (x - c.x) * (x - c.x) + (y - c.y) * (y - c.y);
          image.at<float>(y, x) += 200.0f * float(std::exp(-r2 / (2 * 2.0 * 2.0)));
        }
      }
    }
    return image;
  };
  cv::Mat left, right;
  rectifier.Rectify(render(pts.left_raw), render(pts.right_raw), &left, &right);
  ASSERT_EQ(left.type(), CV_32F);
  auto centroid = [](const cv::Mat& image, cv::Point2f guess) {
    double sw = 0, sx = 0, sy = 0;
    for (int y = int(guess.y) - 7; y <= int(guess.y) + 7; ++y) {
      for (int x = int(guess.x) - 7; x <= int(guess.x) + 7; ++x) {
        const double w = image.at<float>(y, x);
        sw += w;
        sx += w * x;
        sy += w * y;
      }
    }
    return cv::Point2d(sx / sw, sy / sw);
  };
  const auto left_expected = rectifier.RectifyLeftPoints(pts.left_raw);
  const auto right_expected = rectifier.RectifyRightPoints(pts.right_raw);
  const cv::Rect safe(12, 12, rig.image_size.width - 24, rig.image_size.height - 24);
  int checked = 0;
  for (size_t i = 0; i < left_expected.size(); ++i) {
    if (!safe.contains(left_expected[i]) || !safe.contains(right_expected[i])) continue;
    // Dots closer than the window would disturb each other's centroid.
    bool isolated = true;
    for (size_t j = 0; j < left_expected.size(); ++j) {
      if (j != i && (cv::norm(left_expected[i] - left_expected[j]) < 20 ||
                     cv::norm(right_expected[i] - right_expected[j]) < 20)) {
        isolated = false;
      }
    }
    if (!isolated) continue;
    const cv::Point2d l = centroid(left, left_expected[i]);
    const cv::Point2d r = centroid(right, right_expected[i]);
    EXPECT_LT(std::abs(l.y - r.y), 0.05) << "dot " << i;
    EXPECT_LT(cv::norm(l - cv::Point2d(left_expected[i])), 0.1) << "dot " << i;
    ++checked;
  }
  EXPECT_GT(checked, 15);
}

TEST(RectifierTest, StoredMatricesAreUsedAsGiven) {
  StereoCalibration rig = SyntheticRig();
  RectifyOptions full_view;
  full_view.alpha = 1.0;
  const Rectification stored = ComputeRectification(rig, full_view);
  const Rectifier from_stored(
      stored.calibration);  // recompute = false: uses the alpha = 1 matrices
  EXPECT_EQ(cv::norm(from_stored.calibration().P1, stored.calibration.P1), 0.0);
  const Rectifier recomputed(stored.calibration, RectifyOptions{.recompute = true});  // alpha = 0
  EXPECT_GT(recomputed.calibration().P1.at<double>(0, 0), stored.calibration.P1.at<double>(0, 0));
  // Valid rectangles: alpha = 0 is all valid; with alpha = 1 only a part of the view is.
  const cv::Rect whole(0, 0, rig.image_size.width, rig.image_size.height);
  const cv::Rect roi = from_stored.rectification().valid_roi_left;
  EXPECT_GT(roi.area(), whole.area() / 2);
  EXPECT_LT(roi.area(), whole.area());
  EXPECT_EQ(roi & whole, roi);
}

TEST(RectifierTest, RejectsImagesOfAnotherSize) {
  const Rectifier rectifier(SyntheticRig());
  cv::Mat small(240, 376, CV_8U, cv::Scalar(0));
  try {
    rectifier.RectifyLeft(small);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("376x240"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("752x480"), std::string::npos) << e.what();
  }
  EXPECT_THROW(rectifier.RectifyRight(cv::Mat()), InputError);
}

TEST(RectifierTest, RejectsIncompleteCalibration) {
  StereoCalibration rig = SyntheticRig();
  rig.M2 = cv::Mat();
  EXPECT_THROW(Rectifier{rig}, InputError);
}

TEST(RectifierTest, EpipolarCheckImageIsSideBySide) {
  cv::Mat l(48, 64, CV_8U, cv::Scalar(10)), r(48, 64, CV_8U, cv::Scalar(20));
  const cv::Mat check = DrawEpipolarCheck(l, r, 16);
  EXPECT_EQ(check.size(), cv::Size(128, 48));
  EXPECT_EQ(check.type(), CV_8UC3);
  EXPECT_EQ(check.at<cv::Vec3b>(0, 0), cv::Vec3b(10, 10, 10));
  EXPECT_EQ(check.at<cv::Vec3b>(0, 100), cv::Vec3b(20, 20, 20));
  EXPECT_EQ(check.at<cv::Vec3b>(8, 5), cv::Vec3b(0, 0, 255));
}

}  // namespace
}  // namespace linesight
