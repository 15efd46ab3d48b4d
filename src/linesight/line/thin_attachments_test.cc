#include "linesight/line/thin_attachments.h"

#include <cmath>
#include <cstdint>
#include <limits>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "linesight/core/error.h"

namespace linesight {
namespace {

constexpr int kWidth = 320, kHeight = 240;
constexpr double kFocal = 400, kBaseline = 0.1;
constexpr double kLineRow = 80;         // the conductor's image row
constexpr double kLineDisparity = 40;   // its disparity (1 m away)
constexpr double kGroundDisparity = 2;  // the background's
constexpr double kRadius = 0.014;

StereoGeometry Geometry() {
  StereoGeometry g;
  g.focal_px = kFocal;
  g.baseline_m = kBaseline;
  g.cx = kWidth / 2.0;
  g.cy = kHeight / 2.0;
  return g;
}

// A conductor along the image rows at kLineRow, at one depth: its (u, v, d) curve and 3D polyline.
ConductorCurve LevelLine(const StereoGeometry& g) {
  ConductorCurve c;
  c.centre = {kWidth / 2.0, kLineRow};
  c.axis = {1, 0};
  c.normal = {0, 1};
  c.d[0] = kLineDisparity;
  c.tau_min = -kWidth / 2.0;
  c.tau_max = kWidth / 2.0;
  c.radius_m = kRadius;
  const double z = g.DepthFromDisparity(kLineDisparity);
  for (double tau = -400; tau <= 400; tau += 10) {
    const cv::Point2d p = c.ImagePoint(tau);
    c.points.emplace_back((p.x - g.cx) * z / g.focal_px, (p.y - g.cy) * z / g.focal_px, z);
    c.arcs.push_back(
        c.arcs.empty() ? 0.0
                       : c.arcs.back() + cv::norm(c.points.back() - c.points[c.points.size() - 2]));
  }
  return c;
}

// Ground texture that varies along the rows (a value per pixel from a hash).
float Ground(int x, int y) {
  std::uint32_t h =
      static_cast<std::uint32_t>(x) * 73856093u ^ static_cast<std::uint32_t>(y) * 19349663u;
  h ^= h >> 13;
  h *= 0x5bd1e995u;
  h ^= h >> 15;
  return 90.0f + static_cast<float>(h % 60);
}

struct Pair {
  cv::Mat left, right, disparity;
};

// The ground at kGroundDisparity behind the conductor (dark, 6 px across) at kLineDisparity and,
// when string_x >= 0, a dark string 2 px wide hanging string_px from the conductor's lower edge
// at column string_x, also at kLineDisparity. The matcher's map gives the string's pixels the
// background's disparity, as a dense matcher does for a structure this thin.
Pair Scene(int string_x, int string_px, bool striped_ground = false) {
  Pair p;
  p.left.create(kHeight, kWidth, CV_32FC1);
  p.right.create(kHeight, kWidth, CV_32FC1);
  p.disparity.create(kHeight, kWidth, CV_32FC1);
  const int line_from = static_cast<int>(kLineRow) - 3, line_to = static_cast<int>(kLineRow) + 3;
  for (int y = 0; y < kHeight; ++y) {
    for (int view = 0; view < 2; ++view) {
      cv::Mat& image = view == 0 ? p.left : p.right;
      const int shift = view == 0 ? 0 : static_cast<int>(kGroundDisparity);
      const int string_shift = view == 0 ? 0 : static_cast<int>(kLineDisparity);
      for (int x = 0; x < kWidth; ++x) {
        // The scene point seen at x: the ground's texture is fixed to the scene.
        float v = striped_ground ? 90.0f + 40.0f * ((y / 3) % 2) : Ground(x + shift, y);
        if (y >= line_from && y <= line_to) v = 30;
        const int sx = x + string_shift;
        if (string_x >= 0 && y > line_to && y <= line_to + string_px &&
            (sx == string_x || sx == string_x + 1)) {
          v = 20;
        }
        image.at<float>(y, x) = v;
      }
    }
    for (int x = 0; x < kWidth; ++x) {
      const bool on_line = y >= line_from - 2 && y <= line_to + 2;
      p.disparity.at<float>(y, x) = static_cast<float>(on_line ? kLineDisparity : kGroundDisparity);
    }
  }
  return p;
}

std::vector<ThinAttachment> Find(const Pair& p, ThinAttachmentOptions o = {}) {
  const StereoGeometry g = Geometry();
  return FindThinAttachments(p.left, p.right, p.disparity, LevelLine(g), g, kRadius, -150, 150, o);
}

// A string 2 px wide hanging 40 px (10 cm at 1 m) below the line is found where it leaves the line,
// at the line's disparity (which the dense map does not have there), with its length.
TEST(ThinAttachmentsTest, AHangingStringIsFollowedFromTheLineAtItsDepth) {
  const Pair p = Scene(200, 40);
  const std::vector<ThinAttachment> found = Find(p);
  ASSERT_EQ(found.size(), 1u);
  const ThinAttachment& a = found[0];
  EXPECT_NEAR(a.disparity_px, kLineDisparity, 0.5);
  EXPECT_NEAR(a.distance_m, kFocal * kBaseline / kLineDisparity, 0.02);
  const StereoGeometry g = Geometry();
  // 40 px below a 3 px half-band at 1 m: about 40 / 400 m beyond the surface.
  EXPECT_NEAR(a.length_m + kRadius, (3 + 40) / kFocal, 0.02);
  EXPECT_GT(a.down_m, 0.05);
  EXPECT_NEAR(LevelLine(g).ImagePoint(a.root_tau).x, 200.5, 3);
  EXPECT_GE(a.box.x, 198);
  EXPECT_LE(a.box.x + a.box.width, 203);
}

// The clean line on textured ground, and on ground striped along the rows (which matches at any
// disparity), has nothing attached; a string shorter than min_length_m is no structure.
TEST(ThinAttachmentsTest, TheGroundAndAShortStubAreNothing) {
  EXPECT_TRUE(Find(Scene(-1, 0)).empty());
  EXPECT_TRUE(Find(Scene(-1, 0, true)).empty());
  EXPECT_TRUE(Find(Scene(150, 8)).empty());  // 8 px: 2 cm
  EXPECT_EQ(Find(Scene(150, 20)).size(), 1u);
}

// Images of different sizes or types give nothing rather than read out of bounds.
TEST(ThinAttachmentsTest, MismatchedInputsGiveNothing) {
  const Pair p = Scene(200, 40);
  const StereoGeometry g = Geometry();
  const ConductorCurve line = LevelLine(g);
  cv::Mat small = p.right(cv::Rect(0, 0, 100, 100)).clone();
  EXPECT_TRUE(
      FindThinAttachments(p.left, small, p.disparity, line, g, kRadius, -150, 150, {}).empty());
  cv::Mat bytes;
  p.right.convertTo(bytes, CV_8U);
  EXPECT_TRUE(
      FindThinAttachments(p.left, bytes, p.disparity, line, g, kRadius, -150, 150, {}).empty());
}

TEST(ThinAttachmentsTest, BadOptionsNameTheField) {
  EXPECT_NO_THROW(ThinAttachmentOptions().Check());
  ThinAttachmentOptions o;
  o.max_match_ratio = 1.5;
  try {
    o.Check();
    ADD_FAILURE() << "a match ratio of 1.5 passed";
  } catch (const OptionError& e) {
    EXPECT_NE(std::string(e.what()).find("ThinAttachmentOptions.max_match_ratio"),
              std::string::npos);
  }
  o = {};
  o.min_length_m = 0;
  EXPECT_THROW(o.Check(), OptionError);
}

}  // namespace
}  // namespace linesight
