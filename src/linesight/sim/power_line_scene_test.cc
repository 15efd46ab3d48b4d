#include "linesight/sim/power_line_scene.h"

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <random>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "linesight/core/error.h"
#include "linesight/io/image_io.h"
#include "linesight/io/json_io.h"
#include "linesight/io/pfm.h"
#include "linesight/io/stereo_calibration.h"
#include "linesight/sim/sim_internal.h"

namespace linesight::sim {
namespace {

// The default rig at half resolution keeps the tests fast (also under sanitizers).
StereoRigOptions HalfSizeRig() {
  StereoRigOptions rig;
  rig.image_size = {376, 240};
  for (CameraIntrinsics* k : {&rig.left, &rig.right}) {
    k->fx *= 0.5;
    k->fy *= 0.5;
    k->cx = (k->cx + 0.5) * 0.5 - 0.5;
    k->cy = (k->cy + 0.5) * 0.5 - 0.5;
  }
  return rig;
}

PowerLineSceneOptions SmallScene() {
  PowerLineSceneOptions o;
  o.rig = HalfSizeRig();
  o.sensor.supersampling = 2;
  return o;
}

TEST(PowerLineSceneOptions, DefaultsAreValid) {
  EXPECT_NO_THROW(PowerLineSceneOptions().Check());
  EXPECT_NO_THROW(StereoRigOptions().Check());
  EXPECT_NO_THROW(SensorOptions().Check());
}

TEST(PowerLineSceneOptions, RejectsValuesOutsideTheirRange) {
  auto expect_rejected = [](auto mutate, const char* field) {
    PowerLineSceneOptions o;
    mutate(o);
    try {
      o.Check();
      ADD_FAILURE() << "accepted a bad " << field;
    } catch (const OptionError& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  expect_rejected([](auto& o) { o.num_conductors = 0; }, "num_conductors");
  expect_rejected([](auto& o) { o.num_conductors = 5; }, "num_conductors");
  expect_rejected([](auto& o) { o.obstacles[0].distance_m = 0.1; }, "obstacles[0].distance_m");
  expect_rejected([](auto& o) { o.obstacles[1].distance_m = 75; }, "obstacles[1].distance_m");
  expect_rejected([](auto& o) { o.obstacles[2].conductor = 2; }, "obstacles[2].conductor");
  expect_rejected([](auto& o) { o.obstacles[0].tilt_deg = 61; }, "obstacles[0].tilt_deg");
  expect_rejected([](auto& o) { o.obstacles[1].tilt_deg = 5; }, "obstacles[1].tilt_deg");
  expect_rejected([](auto& o) { o.conductor_radius_m = 0.001; }, "conductor_radius_m");
  expect_rejected([](auto& o) { o.conductor_yaw_rad = 0.6; }, "conductor_yaw_rad");
  expect_rejected([](auto& o) { o.tower_offset_x_m = 25; }, "tower_offset_x_m");
  expect_rejected([](auto& o) { o.tower_offset_x_m = std::nan(""); }, "tower_offset_x_m");
  expect_rejected([](auto& o) { o.span_ahead_m = 5; }, "span_ahead_m");
  expect_rejected([](auto& o) { o.cloud_cover = 1.5; }, "cloud_cover");
  expect_rejected([](auto& o) { o.sun_elevation_deg = 2; }, "sun_elevation_deg");
  expect_rejected([](auto& o) { o.sensor.supersampling = 0; }, "supersampling");
  expect_rejected([](auto& o) { o.sensor.supersampling = 9; }, "supersampling");
  expect_rejected([](auto& o) { o.sensor.noise_sigma_dn = -1; }, "noise_sigma_dn");
  expect_rejected([](auto& o) { o.sensor.shot_noise_electrons = 5; }, "shot_noise_electrons");
  expect_rejected([](auto& o) { o.sensor.gamma = 0.5; }, "gamma");
  expect_rejected(
      [](auto& o) {
        o.rig.right_from_left_translation = {0.119, 0, 0};
      },
      "right_from_left_translation");
  expect_rejected([](auto& o) { o.rig.left.distortion[0] = 0.9; }, "distortion.k1");
  expect_rejected(
      [](auto& o) {
        o.rig.right_from_left_rotation = {0.3, 0, 0};
      },
      "right_from_left_rotation");
  // Boundaries that are allowed.
  PowerLineSceneOptions o;
  o.obstacles = {{ObstacleType::kDamper, 0.2, 0}};
  o.num_conductors = 4;
  o.sensor.supersampling = 8;
  EXPECT_NO_THROW(o.Check());
}

TEST(ParseObstacleSpecs, ParsesAndRejects) {
  const auto specs = ParseObstacleSpecs("damper:1.5,clamp:3,insulator:4.5:1,counterweight:0.3");
  ASSERT_EQ(specs.size(), 4u);
  EXPECT_EQ(specs[0].type, ObstacleType::kDamper);
  EXPECT_DOUBLE_EQ(specs[0].distance_m, 1.5);
  EXPECT_EQ(specs[1].type, ObstacleType::kSuspensionClamp);
  EXPECT_EQ(specs[2].type, ObstacleType::kInsulatorString);
  EXPECT_EQ(specs[2].conductor, 1);
  EXPECT_EQ(specs[3].type, ObstacleType::kDamper);
  EXPECT_TRUE(ParseObstacleSpecs("").empty());
  EXPECT_THROW(ParseObstacleSpecs("tree:3"), InputError);
  EXPECT_THROW(ParseObstacleSpecs("damper"), InputError);
  EXPECT_THROW(ParseObstacleSpecs("damper:abc"), InputError);
  EXPECT_THROW(ParseObstacleSpecs("damper:1.5:0.5"), InputError);
  EXPECT_THROW(ParseObstacleSpecs("damper:1.5,"), InputError);
  // A damaged damper's tilt, with or without a conductor index; only dampers tilt.
  const auto tilted = ParseObstacleSpecs("damper:2:tilt=-15,damper:2.5:0:tilt=10");
  ASSERT_EQ(tilted.size(), 2u);
  EXPECT_DOUBLE_EQ(tilted[0].tilt_deg, -15);
  EXPECT_DOUBLE_EQ(tilted[1].tilt_deg, 10);
  EXPECT_EQ(tilted[1].conductor, 0);
  EXPECT_DOUBLE_EQ(specs[0].tilt_deg, 0);
  EXPECT_THROW(ParseObstacleSpecs("clamp:2:tilt=10"), InputError);
  EXPECT_THROW(ParseObstacleSpecs("damper:2:tilt=70"), InputError);
  EXPECT_THROW(ParseObstacleSpecs("damper:2:tilt="), InputError);
  EXPECT_THROW(ParseObstacleSpecs("damper:2:roll=10"), InputError);
  for (ObstacleType type : AllObstacleTypes()) {
    EXPECT_EQ(ParseObstacleType(ObstacleTypeName(type)), type);
  }
}

TEST(MakeStereoCalibration, ModelsTheMyntS1030) {
  const StereoCalibration calib = MakeStereoCalibration(StereoRigOptions());
  EXPECT_EQ(calib.image_size, cv::Size(752, 480));
  EXPECT_NEAR(calib.Baseline(), 0.119, 0.001);
  EXPECT_NEAR(calib.RectifiedFocal(), 736, 20);
  // Rectification matters: R1 is not the identity, the raw cameras differ.
  EXPECT_GT(cv::norm(calib.R1, cv::Mat::eye(3, 3, CV_64F)), 1e-3);
  EXPECT_GT(cv::norm(calib.M1, calib.M2), 1.0);
  EXPECT_GT(cv::norm(calib.D1), 0.01);
  // CALIB_ZERO_DISPARITY: both rectified cameras share the principal point.
  EXPECT_DOUBLE_EQ(calib.P1.at<double>(0, 2), calib.P2.at<double>(0, 2));
  // E and F are consistent with the projection of a point into both raw images.
  const cv::Matx31d x_left(0.3, -0.2, 2.5);
  const cv::Matx31d x_right = cv::Matx33d(calib.R) * x_left + cv::Matx31d(calib.T);
  const cv::Matx31d n_left = x_left * (1.0 / x_left(2));
  const cv::Matx31d n_right = x_right * (1.0 / x_right(2));
  EXPECT_NEAR((n_right.t() * cv::Matx33d(calib.E) * n_left)(0), 0.0, 1e-12);
  const cv::Matx31d p_left = cv::Matx33d(calib.M1) * n_left;
  const cv::Matx31d p_right = cv::Matx33d(calib.M2) * n_right;
  EXPECT_NEAR((p_right.t() * cv::Matx33d(calib.F) * p_left)(0), 0.0, 1e-9);
}

class RenderedSmallScene : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    options_ = new PowerLineSceneOptions(SmallScene());
    options_->sensor.noise_sigma_dn = 0;
    scene_ = new PowerLineScene(RenderPowerLineScene(*options_));
  }
  static void TearDownTestSuite() {
    delete scene_;
    delete options_;
  }
  static PowerLineSceneOptions* options_;
  static PowerLineScene* scene_;
};
PowerLineSceneOptions* RenderedSmallScene::options_ = nullptr;
PowerLineScene* RenderedSmallScene::scene_ = nullptr;

TEST_F(RenderedSmallScene, OutputsHaveTheDocumentedTypes) {
  const PowerLineScene& s = *scene_;
  const cv::Size size = options_->rig.image_size;
  EXPECT_EQ(s.left.size(), size);
  EXPECT_EQ(s.left.type(), CV_8UC3);
  EXPECT_EQ(s.right.type(), CV_8UC3);
  EXPECT_EQ(s.disparity.type(), CV_32FC1);
  EXPECT_EQ(s.depth.type(), CV_32FC1);
  EXPECT_EQ(s.obstacle_mask.type(), CV_8UC1);
  EXPECT_EQ(s.surface_class.type(), CV_8UC1);
  EXPECT_TRUE(s.rectified_left.empty());
  // Sky has no disparity, everything else has a positive one.
  int sky = 0, surfaces = 0;
  for (int v = 0; v < size.height; ++v) {
    for (int u = 0; u < size.width; ++u) {
      const float d = s.disparity.at<float>(v, u);
      const auto cls = static_cast<SurfaceClass>(s.surface_class.at<unsigned char>(v, u));
      if (cls == SurfaceClass::kSky) {
        EXPECT_TRUE(std::isinf(d));
        ++sky;
      } else {
        ASSERT_TRUE(std::isfinite(d) && d > 0) << u << "," << v;
        EXPECT_NEAR(d * s.depth.at<float>(v, u),
                    s.calibration.RectifiedFocal() * s.calibration.Baseline(), 1e-4);
        ++surfaces;
      }
      if (s.obstacle_mask.at<unsigned char>(v, u) != 0) {
        EXPECT_EQ(cls, SurfaceClass::kObstacle);
      }
    }
  }
  EXPECT_GT(sky, size.area() / 10);
  EXPECT_GT(surfaces, size.area() / 10);
}

TEST_F(RenderedSmallScene, ObstaclesAreAtTheRequestedDistance) {
  const PowerLineScene& s = *scene_;
  ASSERT_EQ(s.obstacles.size(), options_->obstacles.size());
  for (const RenderedObstacle& o : s.obstacles) {
    SCOPED_TRACE(ObstacleTypeName(o.type));
    EXPECT_NEAR(o.distance_m, o.requested_distance_m, 1e-4);
    EXPECT_GT(o.visible_pixels, 20);
    // distance_m is the minimum ground-truth depth over the obstacle's pixels.
    double min_depth = 1e9;
    int pixels = 0;
    for (int v = 0; v < s.depth.rows; ++v) {
      for (int u = 0; u < s.depth.cols; ++u) {
        if (s.obstacle_mask.at<unsigned char>(v, u) != o.id) continue;
        ++pixels;
        min_depth = std::min(min_depth, static_cast<double>(s.depth.at<float>(v, u)));
        EXPECT_TRUE(o.box.contains({u, v}));
      }
    }
    EXPECT_EQ(pixels, o.visible_pixels);
    EXPECT_DOUBLE_EQ(min_depth, o.distance_m);
    EXPECT_FLOAT_EQ(s.depth.at<float>(o.nearest_pixel), static_cast<float>(o.distance_m));
    // The whole surface can only be nearer than what is seen, and not by much at this range.
    EXPECT_LE(o.surface_min_depth_m, o.distance_m + 1e-9);
    EXPECT_GT(o.surface_min_depth_m, o.distance_m - 0.01);
  }
}

// The point reconstructed from the rectified ground truth is where a ray from the raw left
// camera centre first meets the geometry, and the raw right camera sees it unless occluded.
TEST_F(RenderedSmallScene, GroundTruthPointsLieOnTheRenderedSurface) {
  const detail::PowerLineSceneModel model = detail::BuildPowerLineSceneModel(*options_);
  const PowerLineScene& s = *scene_;
  const cv::Matx33d r1(s.calibration.R1);
  const double f = s.calibration.P1.at<double>(0, 0), cx = s.calibration.P1.at<double>(0, 2),
               cy = s.calibration.P1.at<double>(1, 2);
  std::mt19937 rng(7);
  int checked = 0, seen_by_right = 0;
  for (int trial = 0; trial < 20000 && checked < 400; ++trial) {
    const int u = static_cast<int>(rng() % s.depth.cols),
              v = static_cast<int>(rng() % s.depth.rows);
    const float d = s.disparity.at<float>(v, u);
    if (!std::isfinite(d)) continue;
    const double z = f * s.calibration.Baseline() / d;
    const cv::Vec3d x_rect((u - cx) * z / f, (v - cy) * z / f, z);
    const cv::Vec3d x_left = r1.t() * x_rect;
    const detail::Vec3 world =
        model.poses.left.camera_from_scene.ApplyTransposed({x_left[0], x_left[1], x_left[2]});
    for (int camera = 0; camera < 2; ++camera) {
      const detail::PosedCamera& pose = camera == 0 ? model.poses.left : model.poses.right;
      const detail::Vec3 to_point = world - pose.centre;
      const double distance = detail::Norm(to_point);
      const detail::Hit hit =
          model.scene.geometry.Intersect({pose.centre, (1.0 / distance) * to_point});
      if (camera == 0) {
        ASSERT_NE(hit.shape, -1);
        EXPECT_NEAR(hit.t, distance, 2e-6 * distance) << u << "," << v;
      } else {
        EXPECT_LE(hit.t, distance * (1 + 2e-6));  // nothing beyond the surface is ever hit first
        if (std::fabs(hit.t - distance) < 2e-6 * distance) ++seen_by_right;
      }
    }
    ++checked;
  }
  EXPECT_EQ(checked, 400);
  EXPECT_GT(seen_by_right, 300);  // occlusion is the exception
}

// Lambertian shading and textures in 3D: a surface point looks the same in both raw images.
TEST_F(RenderedSmallScene, RawImagesAgreeAtGroundTruthCorrespondences) {
  const PowerLineScene& s = *scene_;
  const StereoCalibration& c = s.calibration;
  const double f = c.P1.at<double>(0, 0), cx = c.P1.at<double>(0, 2), cy = c.P1.at<double>(1, 2);
  const cv::Matx33d r1(c.R1);
  cv::Mat left_gray, right_gray;
  cv::cvtColor(s.left, left_gray, cv::COLOR_BGR2GRAY);
  cv::cvtColor(s.right, right_gray, cv::COLOR_BGR2GRAY);
  left_gray.convertTo(left_gray, CV_32F);
  right_gray.convertTo(right_gray, CV_32F);
  std::vector<cv::Point3d> points;
  for (int v = 2; v < s.depth.rows - 2; ++v) {
    for (int u = 2; u < s.depth.cols - 2; ++u) {
      const auto cls = static_cast<SurfaceClass>(s.surface_class.at<unsigned char>(v, u));
      if (cls != SurfaceClass::kObstacle && cls != SurfaceClass::kConductor) continue;
      // Away from depth edges, where anti-aliasing mixes surfaces differently in each view.
      double lo, hi;
      cv::minMaxLoc(s.depth(cv::Rect(u - 1, v - 1, 3, 3)), &lo, &hi);
      if (hi > lo * 1.02) continue;
      const double z = s.depth.at<float>(v, u);
      const cv::Vec3d x_left = r1.t() * cv::Vec3d((u - cx) * z / f, (v - cy) * z / f, z);
      points.emplace_back(x_left[0], x_left[1], x_left[2]);
    }
  }
  ASSERT_GT(points.size(), 100u);
  std::vector<cv::Point2d> in_left, in_right;
  cv::projectPoints(points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), c.M1, c.D1, in_left);
  cv::Vec3d rvec;
  cv::Rodrigues(c.R, rvec);
  cv::projectPoints(points, rvec, cv::Vec3d(c.T), c.M2, c.D2, in_right);
  auto sample = [](const cv::Mat& image, cv::Point2d p) {
    cv::Mat patch;
    cv::getRectSubPix(image, {1, 1}, cv::Point2f(static_cast<float>(p.x), static_cast<float>(p.y)),
                      patch);
    return static_cast<double>(patch.at<float>(0, 0));
  };
  int compared = 0, agree = 0;
  double sum_abs = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    if (in_right[i].x < 1 || in_right[i].y < 1 || in_right[i].x > s.right.cols - 2 ||
        in_right[i].y > s.right.rows - 2) {
      continue;
    }
    const double diff = std::fabs(sample(left_gray, in_left[i]) - sample(right_gray, in_right[i]));
    sum_abs += diff;
    ++compared;
    if (diff < 6) ++agree;
  }
  ASSERT_GT(compared, 100);
  // Bilinear interpolation of strand texture and occlusion by the other view cost a few pixels.
  EXPECT_GT(agree, 0.85 * compared);
  EXPECT_LT(sum_abs / compared, 3.0);  // measured 1.5 DN
  // A wrong correspondence (2 px off along the epipolar line) agrees much less well.
  double shifted_abs = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    if (in_right[i].x < 3 || in_right[i].y < 1 || in_right[i].x > s.right.cols - 4 ||
        in_right[i].y > s.right.rows - 2) {
      continue;
    }
    shifted_abs += std::fabs(sample(left_gray, in_left[i]) -
                             sample(right_gray, in_right[i] + cv::Point2d(2.0, 0.0)));
  }
  EXPECT_GT(shifted_abs / compared, 3.0 * sum_abs / compared);  // measured 8.5 DN
}

TEST(RenderPowerLineScene, DeterministicInTheSeedsAndNoiseOnlyInTheNoiseSeed) {
  PowerLineSceneOptions o = SmallScene();
  o.obstacles = {{ObstacleType::kSuspensionClamp, 2.0, 0}};
  o.sensor.supersampling = 1;
  const PowerLineScene a = RenderPowerLineScene(o);
  const PowerLineScene b = RenderPowerLineScene(o);
  EXPECT_EQ(cv::norm(a.left, b.left, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a.right, b.right, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a.depth != b.depth, cv::NORM_INF), 0.0);
  o.sensor.noise_seed = 12345;
  const PowerLineScene c = RenderPowerLineScene(o);
  EXPECT_GT(cv::norm(a.left, c.left, cv::NORM_L1), 0.0);
  EXPECT_EQ(cv::norm(a.depth != c.depth, cv::NORM_INF), 0.0);  // same geometry
  // Without noise the image does not depend on the noise seed.
  o.sensor.noise_sigma_dn = 0;
  const PowerLineScene quiet1 = RenderPowerLineScene(o);
  o.sensor.noise_seed = 999;
  const PowerLineScene quiet2 = RenderPowerLineScene(o);
  EXPECT_EQ(cv::norm(quiet1.left, quiet2.left, cv::NORM_INF), 0.0);
  // The noise has the requested strength.
  cv::Mat diff;
  cv::absdiff(a.left, quiet1.left, diff);
  cv::Mat diff_float;
  diff.convertTo(diff_float, CV_64F);
  const double rms = std::sqrt(cv::mean(diff_float.mul(diff_float))[0]);
  EXPECT_NEAR(rms, 1.0, 0.15);  // SensorOptions().noise_sigma_dn, plus rounding
  // Another scene seed changes the textures.
  o.seed = 2;
  const PowerLineScene d = RenderPowerLineScene(o);
  EXPECT_GT(cv::norm(quiet2.left, d.left, cv::NORM_L1), 0.0);
}

TEST(PowerLineSceneRenderer, CapturesEqualFreshRendersWithThatNoiseSeed) {
  PowerLineSceneOptions o = SmallScene();
  o.obstacles = {{ObstacleType::kDamper, 2.0, 0}};
  o.sensor.supersampling = 1;
  o.sensor.blur_sigma_px = 0.7;
  o.sensor.shot_noise_electrons = 5000;
  const PowerLineSceneRenderer renderer(o);
  const PowerLineScene first = renderer.Capture(renderer.DefaultNoiseSeed());
  const PowerLineScene reference = RenderPowerLineScene(o);
  EXPECT_EQ(cv::norm(first.left, reference.left, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(first.right, reference.right, cv::NORM_INF), 0.0);
  EXPECT_DOUBLE_EQ(first.obstacles[0].distance_m, reference.obstacles[0].distance_m);
  const PowerLineScene other = renderer.Capture(77);
  o.sensor.noise_seed = 77;
  const PowerLineScene other_reference = RenderPowerLineScene(o);
  EXPECT_EQ(cv::norm(other.left, other_reference.left, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(other.left, first.left, cv::NORM_L1), 0.0);
}

TEST(RenderPowerLineScene, IdealRectifiedPairMatchesTheGroundTruthDisparity) {
  PowerLineSceneOptions o = SmallScene();
  o.obstacles = {{ObstacleType::kDamper, 1.2, 0}};
  o.render_rectified_pair = true;
  o.sensor.noise_sigma_dn = 0;
  const PowerLineScene s = RenderPowerLineScene(o);
  ASSERT_EQ(s.rectified_left.size(), s.left.size());
  cv::Mat left_gray, right_gray;
  cv::cvtColor(s.rectified_left, left_gray, cv::COLOR_BGR2GRAY);
  cv::cvtColor(s.rectified_right, right_gray, cv::COLOR_BGR2GRAY);
  int compared = 0, agree = 0;
  for (int v = 0; v < s.disparity.rows; ++v) {
    for (int u = 2; u < s.disparity.cols - 2; ++u) {
      if (s.obstacle_mask.at<unsigned char>(v, u) == 0) continue;
      const float d = s.disparity.at<float>(v, u);
      const double x = u - d;
      if (x < 0 || x > s.disparity.cols - 2) continue;
      const int x0 = static_cast<int>(std::floor(x));
      const double t = x - x0;
      const double right = (1 - t) * right_gray.at<unsigned char>(v, x0) +
                           t * right_gray.at<unsigned char>(v, x0 + 1);
      ++compared;
      if (std::fabs(right - left_gray.at<unsigned char>(v, u)) < 8) ++agree;
    }
  }
  ASSERT_GT(compared, 50);
  EXPECT_GT(agree, 0.85 * compared);
}

TEST_F(RenderedSmallScene, WritesEveryOutputReadably) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / fmt::format("linesight_sim_test_{}", ::getpid());
  std::filesystem::remove_all(dir);
  WritePowerLineScene(dir / "scene", *scene_);
  const PowerLineScene& s = *scene_;
  const cv::Mat disparity = ReadPfm(dir / "scene" / "disparity_gt.pfm");
  EXPECT_EQ(cv::norm(disparity != s.disparity, cv::NORM_INF), 0.0);  // +inf survives
  const cv::Mat depth = ReadPfm(dir / "scene" / "depth_gt.pfm");
  EXPECT_EQ(cv::norm(depth != s.depth, cv::NORM_INF), 0.0);
  const StereoCalibration calib = ReadStereoCalibration(dir / "scene" / "stereo.yml");
  EXPECT_LT(cv::norm(calib.P2, s.calibration.P2), 1e-9);
  EXPECT_LT(cv::norm(calib.R1, s.calibration.R1), 1e-12);
  const cv::Mat left = ReadImage(dir / "scene" / "left.png", ImageColor::kColor);
  EXPECT_EQ(cv::norm(left, s.left, cv::NORM_INF), 0.0);
  const cv::Mat mask = ReadImage(dir / "scene" / "obstacle_mask.png", ImageColor::kGray);
  EXPECT_EQ(cv::norm(mask, s.obstacle_mask, cv::NORM_INF), 0.0);
  const nlohmann::json json = ReadJson(dir / "scene" / "obstacles.json");
  ASSERT_EQ(json["obstacles"].size(), s.obstacles.size());
  EXPECT_EQ(json["obstacles"][0]["type"], "damper");
  EXPECT_DOUBLE_EQ(json["obstacles"][0]["distance_m"].get<double>(), s.obstacles[0].distance_m);
  EXPECT_FALSE(std::filesystem::exists(dir / "scene" / "rectified_left.png"));
  std::filesystem::remove_all(dir);
}

// Share of the obstacle's nearest-surface pixels (true depth within 1 % of its distance) whose
// correspondence x - d lies inside the rectified right image.
double FrontShareInRightView(const PowerLineScene& scene) {
  const RenderedObstacle& obstacle = scene.obstacles.front();
  int front = 0, inside = 0;
  for (int y = 0; y < scene.depth.rows; ++y) {
    for (int x = 0; x < scene.depth.cols; ++x) {
      if (scene.obstacle_mask.at<uchar>(y, x) != obstacle.id) continue;
      if (scene.depth.at<float>(y, x) > 1.01 * obstacle.distance_m) continue;
      ++front;
      inside += x - scene.disparity.at<float>(y, x) >= 0.0f;
    }
  }
  return front > 0 ? double(inside) / front : 0.0;
}

// The default mounting (line 0.10 m left of and above the rig, heading 0.30 rad to the right)
// puts the nearest surface of every obstacle type at 0.3 m inside both views; looking along a
// line beside the rig (yaw -0.10, the earlier default) it is left of the right camera's view.
TEST(RenderPowerLineScene, DefaultMountingSeesObstaclesAt30CmInBothViews) {
  for (ObstacleType type : AllObstacleTypes()) {
    PowerLineSceneOptions o;
    o.sensor.supersampling = 1;
    o.sensor.noise_sigma_dn = 0;
    o.obstacles = {{type, 0.3, 0}};
    const PowerLineScene scene = RenderPowerLineScene(o);
    ASSERT_EQ(scene.obstacles.size(), 1u);
    EXPECT_NEAR(scene.obstacles.front().distance_m, 0.3, 1e-3);
    EXPECT_GE(FrontShareInRightView(scene), 0.99) << ObstacleTypeName(type);
    o.conductor_yaw_rad = -0.10;
    EXPECT_LE(FrontShareInRightView(RenderPowerLineScene(o)), 0.05) << ObstacleTypeName(type);
  }
}

// The end tower's body moves sideways with tower_offset_x_m: its pixels in the rectified left
// image shift left for a negative offset.
TEST(RenderPowerLineScene, TowerOffsetMovesTheEndTower) {
  auto tower_centre_u = [](double offset) {
    PowerLineSceneOptions o = SmallScene();
    o.obstacles.clear();
    o.tower_offset_x_m = offset;
    o.num_conductors = 1;
    const PowerLineScene scene = RenderPowerLineScene(o);
    double sum = 0;
    int n = 0;
    for (int y = 0; y < scene.surface_class.rows; ++y) {
      for (int x = 0; x < scene.surface_class.cols; ++x) {
        // The end tower stands 80 m ahead: its disparity is below 1.5 px at half size.
        if (scene.surface_class.at<uchar>(y, x) == uchar(SurfaceClass::kTower) &&
            scene.disparity.at<float>(y, x) < 0.8f) {
          sum += x;
          ++n;
        }
      }
    }
    EXPECT_GT(n, 50);
    return sum / std::max(1, n);
  };
  const double centred = tower_centre_u(0.0), moved = tower_centre_u(-8.0);
  // 8 m at about 80 m is about 0.1 rad, 37 px at half size (fx 368); the crossarm stays.
  EXPECT_LT(moved, centred - 15.0) << centred << " " << moved;
}

// A tilted damper swings its weights about the line to the camera's +x (tilt > 0) or -x; its
// clamp stays on the conductor, and its truth carries the tilt.
TEST(RenderPowerLineScene, ATiltedDamperSwingsItsWeightsAside) {
  auto centre_x = [](double tilt) {
    PowerLineSceneOptions o;
    o.sensor.supersampling = 1;
    o.obstacles = {{ObstacleType::kDamper, 1.5, 0}};
    o.obstacles[0].arc_m = 1.7;
    o.obstacles[0].tilt_deg = tilt;
    const PowerLineScene scene = RenderPowerLineScene(o);
    EXPECT_EQ(scene.obstacles[0].tilt_deg, tilt);
    const cv::Rect box = scene.obstacles[0].box;
    EXPECT_GT(box.area(), 0);
    // Mean x of the lower half of the damper's pixels (its weights).
    double sum = 0;
    int count = 0;
    for (int y = box.y + box.height / 2; y < box.y + box.height; ++y) {
      for (int x = box.x; x < box.x + box.width; ++x) {
        if (scene.obstacle_mask.at<std::uint8_t>(y, x) == 1) {
          sum += x;
          ++count;
        }
      }
    }
    EXPECT_GT(count, 0);
    return count > 0 ? sum / count : 0.0;
  };
  const double straight = centre_x(0), right = centre_x(20), left = centre_x(-20);
  EXPECT_GT(right, straight + 3);
  EXPECT_LT(left, straight - 3);
}

TEST(RenderPowerLineScene, RejectsAnObstacleThatCannotBeSeen) {
  PowerLineSceneOptions o = SmallScene();
  o.conductor_offset_x_m =
      -1.5;  // the line passes far to the left: nothing on it is visible close up
  o.conductor_yaw_rad = -0.4;
  o.obstacles = {{ObstacleType::kSuspensionClamp, 0.3, 0}};
  EXPECT_NO_THROW(o.Check());
  try {
    RenderPowerLineScene(o);
    ADD_FAILURE() << "rendered an invisible obstacle";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("not visible"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace linesight::sim
