#include "linesight/calib/camera_model.h"

#include <random>

#include <ceres/jet.h>
#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

#include "linesight/calib/pose.h"

namespace linesight::calib {
namespace {

CameraIntrinsics TestCamera(bool rational) {
  CameraIntrinsics c;
  c.params = {700, 705, 401.5, 299.25, -0.21, 0.08, 0.0012, -0.0008, -0.015, 0, 0, 0};
  if (rational) {
    c.params[kK4] = 0.05;
    c.params[kK5] = -0.01;
    c.params[kK6] = 0.002;
  }
  return c;
}

TEST(CameraModel, MatchesCvProjectPoints) {
  for (bool rational : {false, true}) {
    const CameraIntrinsics camera = TestCamera(rational);
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> lateral(-0.5, 0.5), depth(0.8, 3.0);
    std::vector<cv::Point3d> points;
    for (int i = 0; i < 200; ++i) points.emplace_back(lateral(rng), lateral(rng), depth(rng));
    std::vector<cv::Point2d> expected;
    cv::projectPoints(points, cv::Mat::zeros(3, 1, CV_64F), cv::Mat::zeros(3, 1, CV_64F),
                      camera.CameraMatrix(), camera.Distortion(rational ? 8 : 5), expected);
    for (size_t i = 0; i < points.size(); ++i) {
      const double p[3] = {points[i].x, points[i].y, points[i].z};
      double pixel[2];
      ASSERT_TRUE(Project(camera.params.data(), p, pixel));
      EXPECT_NEAR(pixel[0], expected[i].x, 1e-9);
      EXPECT_NEAR(pixel[1], expected[i].y, 1e-9);
    }
  }
}

TEST(CameraModel, ProjectRejectsPointsBehindTheCamera) {
  const CameraIntrinsics camera = TestCamera(false);
  const double behind[3] = {0.1, 0.2, -1.0};
  const double on_plane[3] = {0.1, 0.2, 0.0};
  double pixel[2];
  EXPECT_FALSE(Project(camera.params.data(), behind, pixel));
  EXPECT_FALSE(Project(camera.params.data(), on_plane, pixel));
}

TEST(CameraModel, UnprojectRoundTrip) {
  for (bool rational : {false, true}) {
    const CameraIntrinsics camera = TestCamera(rational);
    for (double u = 10; u < 800; u += 97) {
      for (double v = 10; v < 600; v += 71) {
        const double pixel[2] = {u, v};
        double normalized[2];
        ASSERT_TRUE(Unproject(camera.params.data(), pixel, normalized)) << u << "," << v;
        const double point[3] = {normalized[0] * 2.5, normalized[1] * 2.5, 2.5};
        double back[2];
        ASSERT_TRUE(Project(camera.params.data(), point, back));
        EXPECT_NEAR(back[0], u, 1e-8);
        EXPECT_NEAR(back[1], v, 1e-8);
      }
    }
  }
}

TEST(CameraModel, UndistortInvertsDistortToMachinePrecision) {
  for (bool rational : {false, true}) {
    const CameraIntrinsics camera = TestCamera(rational);
    for (double x = -0.55; x <= 0.55; x += 0.05) {
      for (double y = -0.4; y <= 0.4; y += 0.05) {
        double xd, yd, xu, yu;
        DistortNormalized(camera.params.data(), x, y, &xd, &yd);
        ASSERT_TRUE(UndistortNormalized(camera.params.data(), xd, yd, &xu, &yu)) << x << "," << y;
        EXPECT_NEAR(xu, x, 1e-14);
        EXPECT_NEAR(yu, y, 1e-14);
      }
    }
  }
}

TEST(CameraModel, UnprojectMatchesCvUndistortPoints) {
  const CameraIntrinsics camera = TestCamera(false);
  std::vector<cv::Point2d> pixels = {{20, 30}, {400, 300}, {780, 580}, {100, 500}};
  std::vector<cv::Point2d> expected;
  cv::undistortPoints(pixels, expected, camera.CameraMatrix(), camera.Distortion(5), cv::noArray(),
                      cv::noArray(), cv::TermCriteria(cv::TermCriteria::COUNT, 200, 0));
  for (size_t i = 0; i < pixels.size(); ++i) {
    const double pixel[2] = {pixels[i].x, pixels[i].y};
    double normalized[2];
    ASSERT_TRUE(Unproject(camera.params.data(), pixel, normalized));
    EXPECT_NEAR(normalized[0], expected[i].x, 1e-7);
    EXPECT_NEAR(normalized[1], expected[i].y, 1e-7);
  }
}

// Autodiff (Jets) of Project through a pose against central differences, for every parameter.
TEST(CameraModel, AutodiffJacobianMatchesNumeric) {
  using Jet = ceres::Jet<double, kNumIntrinsics + kPoseSize>;
  const CameraIntrinsics camera = TestCamera(true);
  const double pose[kPoseSize] = {0.1, -0.2, 0.05, 0.03, -0.02, 1.3};
  const double board_point[3] = {0.12, -0.07, 0.0};
  const auto project = [&](const double* intrinsics, const double* camera_from_board,
                           double* pixel) {
    double p[3];
    TransformPoint(camera_from_board, board_point, p);
    return Project(intrinsics, p, pixel);
  };
  Jet intrinsics[kNumIntrinsics], jet_pose[kPoseSize];
  for (int i = 0; i < kNumIntrinsics; ++i) intrinsics[i] = Jet(camera.params[i], i);
  for (int i = 0; i < kPoseSize; ++i) jet_pose[i] = Jet(pose[i], kNumIntrinsics + i);
  const Jet board[3] = {Jet(board_point[0]), Jet(board_point[1]), Jet(board_point[2])};
  Jet point[3], pixel[2];
  TransformPoint(jet_pose, board, point);
  ASSERT_TRUE(Project(intrinsics, point, pixel));
  for (int column = 0; column < kNumIntrinsics + kPoseSize; ++column) {
    std::array<double, kNumIntrinsics> ip = camera.params, im = camera.params;
    double pp[kPoseSize], pm[kPoseSize];
    std::copy(pose, pose + kPoseSize, pp);
    std::copy(pose, pose + kPoseSize, pm);
    const double h = 1e-6;
    if (column < kNumIntrinsics) {
      ip[column] += h;
      im[column] -= h;
    } else {
      pp[column - kNumIntrinsics] += h;
      pm[column - kNumIntrinsics] -= h;
    }
    double plus[2], minus[2];
    project(ip.data(), pp, plus);
    project(im.data(), pm, minus);
    for (int r = 0; r < 2; ++r) {
      const double numeric = (plus[r] - minus[r]) / (2 * h);
      EXPECT_NEAR(pixel[r].v[column], numeric, 1e-4 * std::max(1.0, std::abs(numeric)))
          << "row " << r << " column " << column;
    }
  }
}

TEST(CameraModel, OpenCVConversionRoundTrip) {
  const CameraIntrinsics camera = TestCamera(true);
  const CameraIntrinsics back =
      CameraIntrinsics::FromOpenCV(camera.CameraMatrix(), camera.Distortion(8));
  for (int i = 0; i < kNumIntrinsics; ++i) EXPECT_EQ(back.params[i], camera.params[i]);
  EXPECT_THROW(CameraIntrinsics::FromOpenCV(cv::Mat::eye(3, 2, CV_64F), cv::Mat()), std::exception);
  EXPECT_THROW(
      CameraIntrinsics::FromOpenCV(cv::Mat::eye(3, 3, CV_64F), cv::Mat::zeros(1, 6, CV_64F)),
      std::exception);
}

TEST(Pose, ComposeAndInverse) {
  Pose a;
  a.params = {0.3, -0.1, 0.2, 0.5, -0.25, 2.0};
  const Pose identity = a * a.Inverse();
  for (double v : identity.params) EXPECT_NEAR(v, 0.0, 1e-12);
  const Eigen::Vector3d p(0.1, 0.2, 0.3);
  EXPECT_NEAR((a.Inverse().Apply(a.Apply(p)) - p).norm(), 0.0, 1e-12);
}

}  // namespace
}  // namespace linesight::calib
