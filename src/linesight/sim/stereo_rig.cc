// The simulated stereo rig (power_line_scene.h, "Camera rig"): option checks, the true calibration
// and the poses of the raw and rectified cameras in a scene's world frame.
#include <cmath>
#include <string>

#include <fmt/format.h>
#include <opencv2/calib3d.hpp>

#include "linesight/core/error.h"
#include "linesight/sim/camera_model.h"
#include "linesight/sim/power_line_scene.h"
#include "linesight/sim/sim_internal.h"

namespace linesight::sim {

using detail::Mat3;
using detail::Vec3;

cv::Matx33d CameraIntrinsics::CameraMatrix() const { return {fx, 0, cx, 0, fy, cy, 0, 0, 1}; }

cv::Mat CameraIntrinsics::DistortionCoefficients() const {
  cv::Mat d(1, 5, CV_64F);
  for (int i = 0; i < 5; ++i) d.at<double>(0, i) = distortion[i];
  return d;
}

namespace {

void CheckIntrinsics(const CameraIntrinsics& c, const std::string& name, cv::Size size) {
  auto field = [&](const char* f) { return name + "." + f; };
  CheckOption(c.fx >= 50 && c.fx <= 20000, field("fx").c_str(), c.fx, "must be in [50, 20000] px");
  CheckOption(c.fy >= 50 && c.fy <= 20000, field("fy").c_str(), c.fy, "must be in [50, 20000] px");
  CheckOption(c.cx >= 0 && c.cx <= size.width, field("cx").c_str(), c.cx,
              "must lie inside the image width");
  CheckOption(c.cy >= 0 && c.cy <= size.height, field("cy").c_str(), c.cy,
              "must lie inside the image height");
  const char* names[5] = {"k1", "k2", "p1", "p2", "k3"};
  const double limits[5] = {0.5, 0.5, 0.02, 0.02, 0.5};
  for (int i = 0; i < 5; ++i) {
    CheckOption(std::isfinite(c.distortion[i]) && std::fabs(c.distortion[i]) <= limits[i],
                field((std::string("distortion.") + names[i]).c_str()).c_str(), c.distortion[i],
                "must be a small lens distortion (|k| <= 0.5, |p| <= 0.02)");
  }
}

}  // namespace

void StereoRigOptions::Check() const {
  CheckOption(image_size.width >= 64 && image_size.height >= 48 && image_size.width <= 8192 &&
                  image_size.height <= 8192,
              "StereoRigOptions.image_size",
              fmt::format("{}x{}", image_size.width, image_size.height),
              "must be between 64x48 and 8192x8192");
  CheckIntrinsics(left, "StereoRigOptions.left", image_size);
  CheckIntrinsics(right, "StereoRigOptions.right", image_size);
  const double angle = cv::norm(right_from_left_rotation);
  CheckOption(angle <= 0.2, "StereoRigOptions.right_from_left_rotation", angle,
              "rotation angle must be <= 0.2 rad (a stereo rig, cameras nearly parallel)");
  const cv::Vec3d& t = right_from_left_translation;
  const double baseline = cv::norm(t);
  CheckOption(baseline >= 0.01 && baseline <= 2.0, "StereoRigOptions.right_from_left_translation",
              baseline, "baseline |T| must be in [0.01, 2] m");
  CheckOption(t[0] < 0 && std::fabs(t[0]) > 0.9 * baseline,
              "StereoRigOptions.right_from_left_translation.x", t[0],
              "must be negative and dominate T (the right camera is to the right of the left one)");
}

StereoCalibration MakeStereoCalibration(const StereoRigOptions& rig) {
  rig.Check();
  StereoCalibration calib;
  calib.image_size = rig.image_size;
  calib.M1 = cv::Mat(rig.left.CameraMatrix()).clone();
  calib.D1 = rig.left.DistortionCoefficients();
  calib.M2 = cv::Mat(rig.right.CameraMatrix()).clone();
  calib.D2 = rig.right.DistortionCoefficients();
  cv::Rodrigues(cv::Mat(rig.right_from_left_rotation), calib.R);
  calib.T = cv::Mat(rig.right_from_left_translation).clone();
  const cv::Vec3d& t = rig.right_from_left_translation;
  const cv::Matx33d tx(0, -t[2], t[1], t[2], 0, -t[0], -t[1], t[0], 0);
  const cv::Matx33d r(calib.R);
  const cv::Matx33d e = tx * r;
  calib.E = cv::Mat(e).clone();
  const cv::Matx33d f = rig.right.CameraMatrix().inv().t() * e * rig.left.CameraMatrix().inv();
  calib.F = cv::Mat(f * (1.0 / f(2, 2))).clone();
  cv::stereoRectify(calib.M1, calib.D1, calib.M2, calib.D2, calib.image_size, calib.R, calib.T,
                    calib.R1, calib.R2, calib.P1, calib.P2, calib.Q, cv::CALIB_ZERO_DISPARITY, 0.0,
                    calib.image_size);
  return calib;
}

namespace detail {

Mat3 FromCv(const cv::Matx33d& m) {
  return {{m(0, 0), m(0, 1), m(0, 2)}, {m(1, 0), m(1, 1), m(1, 2)}, {m(2, 0), m(2, 1), m(2, 2)}};
}

Mat3 Multiply(const Mat3& a, const Mat3& b) {
  const Vec3 c0 = a.Apply({b.r0.x, b.r1.x, b.r2.x});
  const Vec3 c1 = a.Apply({b.r0.y, b.r1.y, b.r2.y});
  const Vec3 c2 = a.Apply({b.r0.z, b.r1.z, b.r2.z});
  return Mat3::FromColumns(c0, c1, c2);
}

CameraIntrinsics RectifiedIntrinsics(const StereoCalibration& calib) {
  CameraIntrinsics k;
  k.fx = calib.P1.at<double>(0, 0);
  k.fy = calib.P1.at<double>(1, 1);
  k.cx = calib.P1.at<double>(0, 2);
  k.cy = calib.P1.at<double>(1, 2);
  return k;
}

RigPoses MakeRigPoses(const StereoCalibration& calib, const Mat3& left_from_world) {
  RigPoses poses;
  const Mat3 right_from_left = FromCv(cv::Matx33d(calib.R));
  const Vec3 t{calib.T.at<double>(0), calib.T.at<double>(1), calib.T.at<double>(2)};
  poses.left = PosedCamera::FromRt(left_from_world, {0, 0, 0});
  poses.right = PosedCamera::FromRt(Multiply(right_from_left, left_from_world), t);
  const Mat3 rect_from_left = FromCv(cv::Matx33d(calib.R1));
  const Mat3 rect_from_world = Multiply(rect_from_left, left_from_world);
  poses.rectified_left = PosedCamera::FromRt(rect_from_world, {0, 0, 0});
  // Both rectified cameras share the orientation R1 (= R2 * R); the right one sits at the true
  // right camera centre.
  poses.rectified_right =
      PosedCamera::FromRt(rect_from_world, -1.0 * rect_from_world.Apply(poses.right.centre));
  return poses;
}

}  // namespace detail

}  // namespace linesight::sim
