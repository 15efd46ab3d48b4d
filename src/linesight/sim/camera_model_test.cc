#include "linesight/sim/camera_model.h"

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

namespace linesight::sim::detail {
namespace {

// The rig's cameras, and one with a stronger lens (k3 and larger tangential terms).
std::vector<CameraIntrinsics> TestCameras() {
  const StereoRigOptions rig;
  return {rig.left, rig.right, {700, 705, 401.5, 299.25, {-0.21, 0.08, 0.0012, -0.0008, -0.015}}};
}

TEST(SimCameraModel, ProjectPointMatchesCvProjectPoints) {
  for (const CameraIntrinsics& camera : TestCameras()) {
    std::vector<cv::Point3d> points;
    for (double x = -0.6; x <= 0.6; x += 0.2) {
      for (double y = -0.4; y <= 0.4; y += 0.2) points.emplace_back(x, y, 1.3 + x * y);
    }
    std::vector<cv::Point2d> expected;
    cv::projectPoints(points, cv::Mat::zeros(3, 1, CV_64F), cv::Mat::zeros(3, 1, CV_64F),
                      cv::Mat(camera.CameraMatrix()), camera.DistortionCoefficients(), expected);
    for (size_t i = 0; i < points.size(); ++i) {
      double u = 0, v = 0;
      ASSERT_TRUE(ProjectPoint(camera, {points[i].x, points[i].y, points[i].z}, &u, &v));
      EXPECT_NEAR(u, expected[i].x, 1e-9);
      EXPECT_NEAR(v, expected[i].y, 1e-9);
    }
  }
}

TEST(SimCameraModel, PixelRayProjectsBackToItsPixel) {
  for (const CameraIntrinsics& camera : TestCameras()) {
    for (double u = 0; u < 752; u += 53.5) {
      for (double v = 0; v < 480; v += 41.25) {
        const Vec3 ray = PixelRay(camera, u, v);
        EXPECT_NEAR(Norm(ray), 1.0, 1e-12);
        double pu = 0, pv = 0;
        ASSERT_TRUE(ProjectPoint(camera, 2.5 * ray, &pu, &pv));
        EXPECT_NEAR(pu, u, 1e-9);
        EXPECT_NEAR(pv, v, 1e-9);
      }
    }
  }
}

TEST(SimCameraModel, PointsBehindTheCameraDoNotProject) {
  double u = 0, v = 0;
  EXPECT_FALSE(ProjectPoint(StereoRigOptions().left, {0.1, 0.2, -1.0}, &u, &v));
  EXPECT_FALSE(ProjectPoint(StereoRigOptions().left, {0.1, 0.2, 0.0}, &u, &v));
}

}  // namespace
}  // namespace linesight::sim::detail
