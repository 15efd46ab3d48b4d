#include "linesight/sim/plate_scene.h"

#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "linesight/core/error.h"
#include "linesight/geometry/depth.h"

namespace linesight::sim {
namespace {

// A textured test image without any file: smooth random blobs.
cv::Mat NoiseTexture(int size, unsigned seed) {
  cv::Mat noise(size, size, CV_32FC3);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::UNIFORM, 0.0, 1.0);
  cv::GaussianBlur(noise, noise, {0, 0}, 1.2);
  cv::normalize(noise, noise, 0, 255, cv::NORM_MINMAX);
  cv::Mat out;
  noise.convertTo(out, CV_8UC3);
  return out;
}

PlateSceneSpec SmallSpec(PlateShape shape, double distance) {
  PlateSceneSpec spec;
  spec.rig.image_size = {320, 240};
  spec.rig.focal_px = 400.0;
  spec.rig.baseline_m = 0.1;
  spec.shape = shape;
  spec.distance_m = distance;
  spec.centre_px = {220, 110};
  spec.plate_texture = NoiseTexture(256, 1);
  spec.background_texture = NoiseTexture(256, 2);
  spec.supersampling = 2;
  return spec;
}

TEST(PlateRigTest, CalibrationIsAnIdealRectifiedPair) {
  PlateRig rig;
  const StereoCalibration c = rig.Calibration();
  EXPECT_NEAR(c.RectifiedFocal(), 736.0, 1e-12);
  EXPECT_NEAR(c.Baseline(), 0.119, 1e-12);
  const StereoGeometry g = GeometryFromCalibration(c);
  EXPECT_NEAR(g.focal_px * g.baseline_m / 25.0, 736.0 * 0.119 / 25.0, 1e-9);
  // Q maps (x, y, d) to the point at Z = f B / d.
  const cv::Mat p = c.Q * (cv::Mat_<double>(4, 1) << 400.0, 200.0, 25.0, 1.0);
  EXPECT_NEAR(p.at<double>(2) / p.at<double>(3), 736.0 * 0.119 / 25.0, 1e-9);
  rig.baseline_m = 0;
  EXPECT_THROW(rig.Calibration(), OptionError);
}

TEST(PlateSceneTest, FrontoParallelPlateHasExactDepthAndShiftsByItsDisparity) {
  const PlateSceneSpec spec = SmallSpec(PlateShape::kPlate, 1.5);
  const PlateRendering r = RenderPlateScene(spec);
  EXPECT_DOUBLE_EQ(r.distance_m, 1.5);
  const double d = 400.0 * 0.1 / 1.5;  // 26.67 px
  // Every object pixel has the plate's depth; the wall (1.5 * 1.5 + 1 m) is behind.
  double min_z = 1e9, max_z = 0;
  for (int y = 0; y < r.depth_gt.rows; ++y) {
    for (int x = 0; x < r.depth_gt.cols; ++x) {
      const float z = r.depth_gt.at<float>(y, x);
      if (r.object_mask.at<uint8_t>(y, x)) {
        min_z = std::min<double>(min_z, z), max_z = std::max<double>(max_z, z);
      } else {
        EXPECT_NEAR(z, 3.25, 1e-5);
      }
    }
  }
  EXPECT_NEAR(min_z, 1.5, 1e-6);
  EXPECT_NEAR(max_z, 1.5, 1e-6);
  EXPECT_NEAR(r.disparity_gt.at<float>(r.box.y + r.box.height / 2, r.box.x + r.box.width / 2), d,
              1e-4);
  // Box: 0.24 m at 1.5 m = 64 px wide.
  EXPECT_NEAR(r.box.width, 0.24 * 400 / 1.5, 1.5);
  EXPECT_NEAR(r.box.height, 0.16 * 400 / 1.5, 1.5);
  // Photometric consistency: inside the plate, right(x - d) == left(x) up to resampling. The best
  // integer-and-quarter shift of a patch is within 0.25 px of d.
  cv::Mat lg, rg;
  cv::cvtColor(r.left, lg, cv::COLOR_BGR2GRAY);
  cv::cvtColor(r.right, rg, cv::COLOR_BGR2GRAY);
  const cv::Rect patch(r.box.x + 10, r.box.y + 8, r.box.width - 20, r.box.height - 16);
  double best_shift = -1, best_error = 1e30;
  for (double shift = d - 3; shift <= d + 3; shift += 0.25) {
    cv::Mat map_x(patch.size(), CV_32F), map_y(patch.size(), CV_32F);
    for (int y = 0; y < patch.height; ++y) {
      for (int x = 0; x < patch.width; ++x) {
        map_x.at<float>(y, x) = static_cast<float>(patch.x + x - shift);
        map_y.at<float>(y, x) = static_cast<float>(patch.y + y);
      }
    }
    cv::Mat warped;
    cv::remap(rg, warped, map_x, map_y, cv::INTER_CUBIC);
    const double error = cv::norm(warped, lg(patch), cv::NORM_L2SQR);
    if (error < best_error) best_error = error, best_shift = shift;
  }
  EXPECT_NEAR(best_shift, d, 0.26);
}

TEST(PlateSceneTest, SlantedPlateAndBoxTruthIsTheNearestVisiblePoint) {
  const PlateRendering slanted = RenderPlateScene(SmallSpec(PlateShape::kSlantedPlate, 2.0));
  // The near edge sits at 2.0 m; pixel centres sample it to within a pixel's depth step.
  EXPECT_GE(slanted.distance_m, 2.0);
  EXPECT_LT(slanted.distance_m, 2.0 + 0.01);
  double max_z = 0;
  for (int y = 0; y < slanted.depth_gt.rows; ++y) {
    for (int x = 0; x < slanted.depth_gt.cols; ++x) {
      if (slanted.object_mask.at<uint8_t>(y, x))
        max_z = std::max<double>(max_z, slanted.depth_gt.at<float>(y, x));
    }
  }
  EXPECT_NEAR(max_z, 2.0 + 0.24 * std::sin(0.6), 0.01);
  const PlateRendering box = RenderPlateScene(SmallSpec(PlateShape::kBox, 1.0));
  EXPECT_NEAR(box.distance_m, 1.0, 1e-6);
  // The box right of the axis shows its left side: object pixels deeper than the front face.
  int side_pixels = 0;
  for (int y = 0; y < box.depth_gt.rows; ++y) {
    for (int x = 0; x < box.depth_gt.cols; ++x) {
      side_pixels += box.object_mask.at<uint8_t>(y, x) && box.depth_gt.at<float>(y, x) > 1.01f;
    }
  }
  EXPECT_GT(side_pixels, 50);
}

TEST(PlateSceneTest, RejectsBadSpecs) {
  PlateSceneSpec spec = SmallSpec(PlateShape::kPlate, 1.0);
  spec.plate_texture = cv::Mat();
  EXPECT_THROW(RenderPlateScene(spec), OptionError);
  spec = SmallSpec(PlateShape::kPlate, 1.0);
  spec.background_m = 0.5;  // in front of the plate
  EXPECT_THROW(RenderPlateScene(spec), OptionError);
  spec = SmallSpec(PlateShape::kPlate, 1.0);
  spec.centre_px = {5000, 110};  // outside the image
  EXPECT_THROW(RenderPlateScene(spec), InputError);
  EXPECT_THROW(ParsePlateShape("sphere"), UsageError);
  EXPECT_EQ(ParsePlateShape("box"), PlateShape::kBox);
}

TEST(PlateSceneTest, CaptureIsDeterministicAndNoisy) {
  const PlateRendering r = RenderPlateScene(SmallSpec(PlateShape::kPlate, 1.0));
  const cv::Mat a = CapturePlateImage(r.left, 1.0, 7), b = CapturePlateImage(r.left, 1.0, 7);
  const cv::Mat c = CapturePlateImage(r.left, 1.0, 8), clean = CapturePlateImage(r.left, 0.0, 7);
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(a, c, cv::NORM_L1), 0.0);
  cv::Mat diff;
  cv::absdiff(a, clean, diff);
  EXPECT_LE(cv::norm(diff, cv::NORM_INF), 6.0);  // 1 DN noise: |n| < 6 sigma
  EXPECT_EQ(a.type(), CV_8UC3);
}

}  // namespace
}  // namespace linesight::sim
