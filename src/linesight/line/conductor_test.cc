#include "linesight/line/conductor.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>

#include <opencv2/imgproc.hpp>

#include <gtest/gtest.h>

#include "linesight/core/error.h"
#include "linesight/line/line_test_util.h"
#include "linesight/ranging/pipeline.h"
#include "linesight/sim/power_line_sequence.h"

namespace linesight {
namespace {

// Largest distance of the fitted axis from the true axis over arcs [from, to] (m), and the arc
// error at the true point of arc `at`.
struct AxisError {
  double max_offset_m = 0, arc_error_m = 0;
};
AxisError CompareAxis(const ConductorModel& model, const sim::PowerLineScene& scene, double from,
                      double to) {
  AxisError e;
  for (const sim::ConductorAxisPoint& p : scene.conductor_axis) {
    if (p.arc_m < from || p.arc_m > to) continue;
    const LinePosition at = model.Locate(p.rect);
    if (std::getenv("DUMP") && std::fmod(p.arc_m + 1e-6, 0.5) < 0.01)
      std::printf("  arc %.2f off %.4f down %.4f side %.4f z %.2f\n", p.arc_m, at.offset_m,
                  at.down_m, at.side_m, p.rect.z);
    e.max_offset_m = std::max(e.max_offset_m, at.offset_m);
    e.arc_error_m = std::max(e.arc_error_m, std::fabs(at.arc_m - p.arc_m));
  }
  return e;
}

StereoGeometry TrueGeometry(const sim::PowerLineScene& scene) {
  return GeometryFromCalibration(scene.calibration);
}

// Exact disparities: no edge fattening, no matching noise.
ConductorOptions Exact() {
  ConductorOptions o;
  o.fattening_px = 0;
  return o;
}

TEST(ConductorTest, FollowsTheTrueAxisOnExactDisparities) {
  for (std::uint64_t seed : {3u, 5u}) {
    const sim::PowerLineSequence sequence(testing::FastSequence(seed));
    for (int index : {0, sequence.size() / 2}) {
      const sim::PowerLineScene scene = sequence.Render(index);
      const ConductorModel model = FitConductor(scene.disparity, TrueGeometry(scene), Exact());
      if (!model.ok()) {
        std::printf("%s\n", model.ToJson().dump(1).c_str());
      }
      ASSERT_TRUE(model.ok()) << model.reason;
      const AxisError e = CompareAxis(model, scene, 0.5, 6.0);
      EXPECT_LT(e.max_offset_m, 0.02);
      EXPECT_LT(e.arc_error_m, 0.005);
      EXPECT_NEAR(model.line.radius_m, 0.014, 0.002);
    }
  }
}

RangingPipelineOptions OnOneThread() {
  RangingPipelineOptions options;
  options.threads = 1;
  return options;
}

// Frame `index` of sequence `seed`, rectified and matched by the ranging chain (isgm).
struct MatchedFrame {
  MatchedFrame(std::uint64_t seed, int index)
      : scene(sim::PowerLineSequence(testing::FastSequence(seed)).Render(index)),
        pipeline(scene.calibration, OnOneThread()),
        frame(pipeline.Process(scene.left, scene.right)) {}
  sim::PowerLineScene scene;
  RangingPipeline pipeline;
  RangingFrame frame;
};

TEST(ConductorTest, FollowsTheTrueAxisOnMatchedDisparities) {
  const MatchedFrame m(7, 10);
  for (const cv::Mat* d : {&m.frame.disparity, &m.frame.checked_disparity}) {
    const ConductorModel model = FitConductor(*d, m.pipeline.geometry(), {});
    ASSERT_TRUE(model.ok()) << model.reason;
    const AxisError e = CompareAxis(model, m.scene, 0.5, 6.0);
    // Arc lengths, which the distances along the line are read from, hold to a few millimetres,
    // and so does the axis (7.5 mm): a straight line through a 14 mm tube's noisy, fattened image.
    EXPECT_LT(e.max_offset_m, 0.03);
    EXPECT_LT(e.arc_error_m, 0.01);
  }
}

// The line runs into an insulator string's clamp 4.2 m ahead (seed 7, frame 120) and its near end
// is a 40 px wide band at the image's top: the matched map's pixels of both are inliers. The
// straight line in (u, v, d) stays on the axis (1.8 cm); a cubic there bends through them (9 cm
// off at the clamp).
TEST(ConductorTest, AnObstacleAtTheFarEndDoesNotBendTheLine) {
  const MatchedFrame m(7, 120);
  const ConductorModel model = FitConductor(m.frame.disparity, m.pipeline.geometry(), {});
  ASSERT_TRUE(model.ok()) << model.reason;
  const AxisError e = CompareAxis(model, m.scene, 0.5, 4.2);
  EXPECT_LT(e.max_offset_m, 0.03);
  EXPECT_LT(e.arc_error_m, 0.01);
}

// A synthetic rectified disparity map: f = 700 px, B = 0.1 m, principal point at the centre.
StereoGeometry SyntheticGeometry() { return {700.0, 0.1, 0.0, 376.0, 240.0}; }

// Draws the image of the 3D segment a-b as a tube of `radius` (m) into `disparity`.
void DrawTube(cv::Mat* disparity, const StereoGeometry& g, cv::Point3d a, cv::Point3d b,
              double radius) {
  const int steps = 2000;
  for (int s = 0; s <= steps; ++s) {
    const cv::Point3d x = a + (b - a) * (double(s) / steps);
    if (x.z < 0.2) continue;
    const cv::Point2d p(g.focal_px * x.x / x.z + g.cx, g.focal_px * x.y / x.z + g.cy);
    const float d = static_cast<float>(g.DisparityFromDepth(x.z));
    const int r = std::max(1, int(std::lround(radius * g.focal_px / x.z)));
    cv::circle(*disparity, cv::Point(int(std::lround(p.x)), int(std::lround(p.y))), r,
               cv::Scalar(d), cv::FILLED);
  }
}

cv::Mat EmptyDisparity() {
  return cv::Mat(480, 752, CV_32FC1, cv::Scalar(std::numeric_limits<float>::infinity()));
}

TEST(ConductorTest, ASingleSyntheticTubeIsTheConductor) {
  const StereoGeometry g = SyntheticGeometry();
  cv::Mat d = EmptyDisparity();
  DrawTube(&d, g, {0.05, -0.1, 0.3}, {0.6, 0.8, 8.0}, 0.014);
  const ConductorModel model = FitConductor(d, g, {});
  ASSERT_TRUE(model.ok()) << model.reason;
  EXPECT_TRUE(model.others.empty());
  // The line's nearest point to the camera: the segment's direction and the closest approach.
  const cv::Vec3d dir = cv::normalize(cv::Vec3d(0.55, 0.9, 7.7));
  const cv::Vec3d a(0.05, -0.1, 0.3);
  const double closest = cv::norm(a - a.dot(dir) * dir);
  EXPECT_NEAR(model.line.closest_approach_m, closest, 0.03);
  const LinePosition far = model.Locate({0.6, 0.8, 8.0});
  EXPECT_LT(far.offset_m, 0.05);
  EXPECT_NEAR(far.arc_m,
              cv::norm(cv::Vec3d(0.6, 0.8, 8.0)) * dir.dot(cv::normalize(cv::Vec3d(0.6, 0.8, 8.0))),
              0.05);
  const nlohmann::json j = model.ToJson();
  EXPECT_EQ(j["status"], "ok");
  EXPECT_GT(j["line"]["axis_arc_xyz_m"].size(), 3u);
}

TEST(ConductorTest, SaysWhyWhenThereIsNoUsableLine) {
  const StereoGeometry g = SyntheticGeometry();
  // Nothing in the working range.
  EXPECT_EQ(FitConductor(EmptyDisparity(), g, {}).status, ConductorStatus::kNoDisparity);
  // Only a body (a 30 cm box at 2 m): no thin structure.
  cv::Mat box = EmptyDisparity();
  box(cv::Rect(300, 200, 105, 105)).setTo(g.DisparityFromDepth(2.0));
  const ConductorModel body = FitConductor(box, g, {});
  EXPECT_EQ(body.status, ConductorStatus::kNoConductor);
  EXPECT_FALSE(body.reason.empty());
  // A conductor seen end-on: a short stub in the image.
  cv::Mat stub = EmptyDisparity();
  DrawTube(&stub, g, {0.05, 0.10, 1.0}, {0.16, 0.31, 3.0}, 0.014);
  const ConductorModel end_on = FitConductor(stub, g, {});
  EXPECT_EQ(end_on.status, ConductorStatus::kEndOn) << end_on.reason;
  // Two conductors crossing in front of the camera, both as near: which one is not clear.
  cv::Mat crossing = EmptyDisparity();
  DrawTube(&crossing, g, {-0.3, 0.1, 0.3}, {2.0, 0.6, 8.0}, 0.014);
  DrawTube(&crossing, g, {0.3, 0.1, 0.3}, {-2.0, 0.6, 8.0}, 0.014);
  const ConductorModel two = FitConductor(crossing, g, {});
  EXPECT_EQ(two.status, ConductorStatus::kAmbiguous) << two.reason;
  EXPECT_FALSE(two.ok());
}

TEST(ConductorTest, ATrackedConductorStaysTheRobotsWhenAnotherPassesAsNear) {
  const StereoGeometry g = SyntheticGeometry();
  const cv::Point3d a0(-0.3, 0.1, 0.3), a1(2.0, 0.6, 8.0);
  cv::Mat alone = EmptyDisparity();
  DrawTube(&alone, g, a0, a1, 0.014);
  const ConductorModel tracked = FitConductor(alone, g, {});
  ASSERT_TRUE(tracked.ok()) << tracked.reason;
  // The next frame: a second conductor crosses in front of the camera as near as the first.
  cv::Mat crossing = alone.clone();
  DrawTube(&crossing, g, {0.3, 0.1, 0.3}, {-2.0, 0.6, 8.0}, 0.014);
  ASSERT_EQ(FitConductor(crossing, g, {}).status, ConductorStatus::kAmbiguous);
  const ConductorModel next = FitConductor(crossing, g, {}, cv::Mat(), &tracked);
  ASSERT_TRUE(next.ok()) << next.reason;
  // The model is the tracked line, the crossing one is another conductor.
  for (const double t : {0.1, 0.5, 0.9}) {
    EXPECT_LT(next.Locate(a0 + (a1 - a0) * t).offset_m, 0.03) << t;
  }
  ASSERT_EQ(next.others.size(), 1u);
  EXPECT_GT(next.Locate({-0.9, 0.35, 4.0}).offset_m, 0.5);
}

TEST(ConductorTest, ALineWithoutWidthIsNoConductor) {
  const StereoGeometry g = SyntheticGeometry();
  cv::Mat d = EmptyDisparity();
  DrawTube(&d, g, {0.05, -0.1, 0.3}, {0.6, 0.8, 8.0}, 0.014);
  // Beside it, a line of near disparities no wider than the matcher's fattening (fill lined up by
  // chance, 3 px across from 0.3 to 2 m) that passes nearer the camera than the conductor.
  cv::Mat fill = EmptyDisparity();
  DrawTube(&fill, g, {-0.12, -0.1, 0.3}, {-1.0, -0.3, 2.0}, 0.0);
  fill.copyTo(d, fill < std::numeric_limits<float>::infinity());
  ConductorOptions without_rule;
  without_rule.min_radius_m = 0.0;
  // Without the width test the fill, passing nearer, is taken for the robot's conductor.
  const ConductorModel taken = FitConductor(d, g, without_rule);
  ASSERT_TRUE(taken.ok()) << taken.reason;
  EXPECT_LT(taken.line.radius_m, 0.003);
  const ConductorModel model = FitConductor(d, g, {});
  ASSERT_TRUE(model.ok()) << model.reason;
  EXPECT_TRUE(model.others.empty());
  EXPECT_GT(model.line.radius_m, 0.01);
}

TEST(ConductorTest, RejectsBadOptionsAndMaps) {
  ConductorOptions o;
  o.max_depth_m = 0.1;
  EXPECT_THROW(FitConductor(EmptyDisparity(), SyntheticGeometry(), o), OptionError);
  EXPECT_THROW(FitConductor(cv::Mat(10, 10, CV_8UC1), SyntheticGeometry(), {}), InputError);
  for (int degree : {0, 4}) {
    ConductorOptions bad;
    bad.curve_degree = degree;
    EXPECT_THROW(FitConductor(EmptyDisparity(), SyntheticGeometry(), bad), OptionError);
  }
}

// The naive reference of CurveLocator: every segment's frame worked out for every point.
LinePosition ReferenceLocate(const ConductorCurve& k, const cv::Point3d& x) {
  LinePosition best;
  double best_dist = std::numeric_limits<double>::infinity();
  const size_t n = k.points.size();
  for (size_t i = 0; i + 1 < n; ++i) {
    const cv::Point3d a = k.points[i], b = k.points[i + 1];
    const cv::Point3d ab = b - a;
    const double len2 = ab.dot(ab);
    double f = (x - a).dot(ab) / len2;
    // The end segments extend the line beyond the polyline.
    const double lo = i == 0 ? -1e9 : 0.0, hi = i + 2 == n ? 1e9 : 1.0;
    f = std::clamp(f, lo, hi);
    const cv::Point3d foot = a + f * ab;
    const double dist = cv::norm(x - foot);
    if (dist < best_dist) {
      best_dist = dist;
      const double len = std::sqrt(len2);
      best.arc_m = k.arcs[i] + f * len;
      best.offset_m = dist;
      const cv::Vec3d t(ab.x / len, ab.y / len, ab.z / len);
      cv::Vec3d down = cv::Vec3d(0, 1, 0) - t[1] * t;
      down *= 1.0 / cv::norm(down);
      const cv::Vec3d side = t.cross(down);
      const cv::Vec3d e(x.x - foot.x, x.y - foot.y, x.z - foot.z);
      best.down_m = e.dot(down);
      best.side_m = e.dot(side);
      best.tangent = t;
    }
  }
  return best;
}

// CurveLocator works each segment's frame out once and searches a tree of segments: it must give
// the reference's bits on awkward curves (2 points, a kink, near-duplicate points, a vertical
// segment, a long sagging polyline, a 400-point polyline that winds back on itself with repeated
// points) for points beside, beyond and behind them.
TEST(CurveLocatorTest, EqualsTheNaiveReferenceBitForBit) {
  cv::RNG rng(11);
  std::vector<std::vector<cv::Point3d>> polylines = {
      {{0, 0, 1}, {0.1, 0.02, 3}},
      {{0, 0, 1}, {0.2, 0.1, 2}, {-0.1, 0.3, 2.5}},
      {{0, 0, 1}, {1e-7, 0, 1 + 1e-7}, {0.05, 0.01, 2}},
      {{0.1, -0.5, 2}, {0.1, 0.5, 2}, {0.2, 0.6, 3}}};
  std::vector<cv::Point3d> sag;
  for (int i = 0; i < 61; ++i) {
    const double t = i / 60.0;
    sag.push_back({0.3 * t, 0.2 * (t - 0.5) * (t - 0.5), 0.5 + 7.5 * t});
  }
  polylines.push_back(sag);
  // Long enough for a deep tree of segments, with repeated points and a loop back on itself.
  std::vector<cv::Point3d> wiggle;
  for (int i = 0; i < 413; ++i) {
    const double t = i / 412.0;
    wiggle.push_back({0.2 * std::sin(40 * t), 0.1 * std::cos(25 * t), 0.4 + 8 * t * (1.2 - t)});
    if (i % 97 == 5) wiggle.push_back(wiggle.back());
  }
  polylines.push_back(wiggle);
  for (const auto& points : polylines) {
    ConductorCurve curve;
    curve.points = points;
    double arc = -0.3;
    for (size_t i = 0; i < points.size(); ++i) {
      if (i > 0) arc += cv::norm(points[i] - points[i - 1]);
      curve.arcs.push_back(arc);
    }
    const CurveLocator locator(curve);
    for (int k = 0; k < 2000; ++k) {
      // Points anywhere, and points a few centimetres from the polyline (most pixels' case).
      const cv::Point3d near = points[size_t(rng.uniform(0, int(points.size())))];
      const cv::Point3d x =
          k % 2 == 0
              ? cv::Point3d(rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 9.0))
              : near + cv::Point3d(rng.gaussian(0.05), rng.gaussian(0.05), rng.gaussian(0.05));
      const LinePosition want = ReferenceLocate(curve, x), got = locator.Locate(x);
      // Bits, not values: a vertical segment has no "down" and both give the same NaN there.
      const auto bits = [](double v) { return std::bit_cast<std::uint64_t>(v); };
      ASSERT_EQ(bits(got.arc_m), bits(want.arc_m)) << points.size() << " points, k " << k;
      ASSERT_EQ(bits(got.offset_m), bits(want.offset_m));
      ASSERT_EQ(bits(got.down_m), bits(want.down_m));
      ASSERT_EQ(bits(got.side_m), bits(want.side_m));
      for (int c = 0; c < 3; ++c) ASSERT_EQ(bits(got.tangent[c]), bits(want.tangent[c]));
    }
  }
  const LinePosition none = CurveLocator(ConductorCurve{}).Locate({0, 0, 1});
  EXPECT_EQ(none.arc_m, 0.0);
  EXPECT_EQ(none.offset_m, 0.0);
}

}  // namespace
}  // namespace linesight
