#include "linesight/sim/power_line_sequence.h"

#include <cmath>

#include <gtest/gtest.h>

#include "linesight/core/error.h"

namespace linesight::sim {
namespace {

PowerLineSequenceOptions FastSequence(std::uint64_t seed) {
  PowerLineSequenceOptions o;
  o.seed = seed;
  o.scene.sensor.supersampling = 1;
  o.fps = 2.0;
  return o;
}

TEST(PowerLineSequence, LayoutStartsAtTheGapAndFramesCoverTheApproach) {
  const PowerLineSequence sequence(FastSequence(4));
  const auto& o = sequence.options();
  ASSERT_EQ(sequence.layout().size(), 3u);
  const auto& first = sequence.layout().front();
  EXPECT_NEAR(first.arc_m + ObstacleAlongExtent(first.type)[0], o.start_gap_m, 1e-12);
  for (size_t i = 1; i < sequence.layout().size(); ++i) {
    const auto& a = sequence.layout()[i - 1];
    const auto& b = sequence.layout()[i];
    const double gap =
        (b.arc_m + ObstacleAlongExtent(b.type)[0]) - (a.arc_m + ObstacleAlongExtent(a.type)[1]);
    EXPECT_GE(gap, o.min_spacing_m - 1e-12);
    EXPECT_LE(gap, o.max_spacing_m + 1e-12);
  }
  // (6 - 0.4) / 0.3 * 2 = 37.3 -> 38 frames; the last one leaves the first obstacle >= 0.4 m ahead.
  EXPECT_EQ(sequence.size(), 38);
  const double last_gap = o.start_gap_m - sequence.TravelledAt(sequence.size() - 1);
  EXPECT_GE(last_gap, o.end_gap_m - 1e-9);
  EXPECT_LT(last_gap, o.end_gap_m + o.speed_mps / o.fps);
}

TEST(PowerLineSequence, FramesMoveTheObstaclesAndJitterThePose) {
  const PowerLineSequence sequence(FastSequence(4));
  const PowerLineSceneOptions a = sequence.FrameOptions(0);
  const PowerLineSceneOptions b = sequence.FrameOptions(10);
  ASSERT_EQ(a.obstacles.size(), b.obstacles.size());
  for (size_t i = 0; i < a.obstacles.size(); ++i) {
    EXPECT_NEAR(*a.obstacles[i].arc_m - *b.obstacles[i].arc_m, 10 * 0.3 / 2.0, 1e-12);
  }
  EXPECT_NE(a.conductor_pitch_rad, b.conductor_pitch_rad);
  EXPECT_NE(a.conductor_roll_rad, b.conductor_roll_rad);
  EXPECT_NE(a.conductor_offset_y_m, b.conductor_offset_y_m);
  EXPECT_LE(std::fabs(a.conductor_pitch_rad), 0.3 * M_PI / 180 + 1e-12);
  EXPECT_LE(std::fabs(b.conductor_offset_y_m - PowerLineSceneOptions{}.conductor_offset_y_m),
            0.004 + 1e-12);
  EXPECT_NE(a.sensor.noise_seed, b.sensor.noise_seed);
  // Another seed lays the line out differently.
  const PowerLineSequence other(FastSequence(5));
  bool differs = false;
  for (size_t i = 0; i < 3; ++i) {
    differs |= other.layout()[i].type != sequence.layout()[i].type ||
               other.layout()[i].arc_m != sequence.layout()[i].arc_m;
  }
  EXPECT_TRUE(differs);
}

TEST(PowerLineSequence, RenderedTruthApproachesAndFramesAreIndependent) {
  PowerLineSequenceOptions o = FastSequence(2);
  o.num_obstacles = 1;
  o.start_gap_m = 3.0;
  o.end_gap_m = 1.0;
  o.scene.towers = false;
  o.scene.cloud_cover = 0.0;
  const PowerLineSequence sequence(o);
  const int last = sequence.size() - 1;
  const PowerLineScene far = sequence.Render(0);
  const PowerLineScene near = sequence.Render(last);
  ASSERT_EQ(far.obstacles.size(), 1u);
  EXPECT_NEAR(far.obstacles[0].near_arc_m, 3.0, 1e-9);
  EXPECT_NEAR(near.obstacles[0].near_arc_m, 3.0 - sequence.TravelledAt(last), 1e-9);
  ASSERT_GT(far.obstacles[0].visible_pixels, 0);
  ASSERT_GT(near.obstacles[0].visible_pixels, far.obstacles[0].visible_pixels);
  // The straight distance follows the arc: the line heads away from the camera at a small angle.
  EXPECT_LT(near.obstacles[0].distance_m, far.obstacles[0].distance_m - 1.5);
  EXPECT_GT(far.obstacles[0].distance_m, 0.85 * far.obstacles[0].near_arc_m);
  // The conductor axis is sampled along the arc and lies in front of the camera ahead.
  ASSERT_FALSE(far.conductor_axis.empty());
  for (const ConductorAxisPoint& p : far.conductor_axis) {
    if (p.arc_m > 0.5) {
      EXPECT_GT(p.rect.z, 0.0);
    }
  }
  // Frame `last` rendered on its own equals the same frame rendered after others.
  const PowerLineScene again = sequence.Render(last);
  EXPECT_EQ(cv::norm(again.left, near.left, cv::NORM_INF), 0.0);
  EXPECT_EQ(again.obstacles[0].distance_m, near.obstacles[0].distance_m);
  // Truth JSON names the obstacle, its arc and straight distances.
  const nlohmann::json truth =
      SequenceFrameTruthToJson(last, sequence.TimestampOf(last), sequence.TravelledAt(last), near);
  EXPECT_EQ(truth["obstacles"][0]["type"], ObstacleTypeName(sequence.layout()[0].type));
  EXPECT_DOUBLE_EQ(truth["obstacles"][0]["distance_m"].get<double>(), near.obstacles[0].distance_m);
}

// Defects come from a stream of their own: the obstacles, the motion and the noise are those of
// the same sequence without them; they move with the line and every frame has their truth.
TEST(PowerLineSequence, DefectsComeWithTruthAndLeaveTheObstaclesAlone) {
  PowerLineSequenceOptions o = FastSequence(4);
  const PowerLineSequence plain(o);
  o.num_defects = 2;
  const PowerLineSequence defective(o);
  EXPECT_TRUE(plain.defects().empty());
  ASSERT_EQ(defective.defects().size(), 2u);
  ASSERT_EQ(defective.size(), plain.size());
  ASSERT_EQ(defective.layout().size(), plain.layout().size());
  for (size_t i = 0; i < plain.layout().size(); ++i) {
    EXPECT_EQ(defective.layout()[i].type, plain.layout()[i].type);
    EXPECT_EQ(defective.layout()[i].arc_m, plain.layout()[i].arc_m);
  }
  for (const DefectSpec& d : defective.defects()) {
    EXPECT_GE(d.arc_m, 0.5);
    EXPECT_LE(d.arc_m, defective.layout().back().arc_m);
  }
  EXPECT_GE(defective.defects()[1].arc_m - defective.defects()[0].arc_m, 0.5 - 1e-12);
  for (int k : {0, 7}) {
    const PowerLineSceneOptions a = plain.FrameOptions(k);
    const PowerLineSceneOptions b = defective.FrameOptions(k);
    EXPECT_TRUE(a.defects.empty());
    ASSERT_EQ(b.defects.size(), 2u);
    for (size_t i = 0; i < 2; ++i) {
      EXPECT_NEAR(b.defects[i].arc_m, defective.defects()[i].arc_m - defective.TravelledAt(k),
                  1e-12);
      EXPECT_EQ(b.defects[i].type, defective.defects()[i].type);
    }
    ASSERT_EQ(a.obstacles.size(), b.obstacles.size());
    for (size_t i = 0; i < a.obstacles.size(); ++i) {
      EXPECT_EQ(a.obstacles[i].type, b.obstacles[i].type);
      EXPECT_EQ(*a.obstacles[i].arc_m, *b.obstacles[i].arc_m);
    }
    EXPECT_EQ(a.conductor_pitch_rad, b.conductor_pitch_rad);
    EXPECT_EQ(a.conductor_roll_rad, b.conductor_roll_rad);
    EXPECT_EQ(a.conductor_offset_y_m, b.conductor_offset_y_m);
    EXPECT_EQ(a.sensor.noise_seed, b.sensor.noise_seed);
    EXPECT_EQ(a.span_ahead_m, b.span_ahead_m);
  }
  // Rendered truth: the defects with their arcs from the robot; the obstacles where they were.
  const int k = 4;
  const PowerLineScene with = defective.Render(k);
  const PowerLineScene without = plain.Render(k);
  ASSERT_EQ(with.defects.size(), 2u);
  ASSERT_EQ(with.obstacles.size(), without.obstacles.size());
  for (size_t i = 0; i < with.obstacles.size(); ++i) {
    EXPECT_EQ(with.obstacles[i].type, without.obstacles[i].type);
    EXPECT_EQ(with.obstacles[i].near_arc_m, without.obstacles[i].near_arc_m);
  }
  const nlohmann::json truth =
      SequenceFrameTruthToJson(k, defective.TimestampOf(k), defective.TravelledAt(k), with);
  ASSERT_TRUE(truth.contains("defects"));
  ASSERT_EQ(truth["defects"].size(), 2u);
  int visible = 0;
  for (size_t i = 0; i < 2; ++i) {
    const nlohmann::json& d = truth["defects"][i];
    const RenderedDefect& r = with.defects[i];
    EXPECT_EQ(d["id"], static_cast<int>(i) + 1);
    EXPECT_EQ(d["type"], DefectTypeName(defective.defects()[i].type));
    EXPECT_NEAR(d["arc_distance_m"].get<double>(),
                defective.defects()[i].arc_m - defective.TravelledAt(k), 1e-12);
    EXPECT_LT(d["arc_begin_m"].get<double>(), d["arc_distance_m"].get<double>());
    EXPECT_GT(d["arc_end_m"].get<double>(), d["arc_distance_m"].get<double>());
    EXPECT_DOUBLE_EQ(d["size_m"].get<double>(), r.size_m);
    EXPECT_EQ(d["visible_pixels"], r.visible_pixels);
    EXPECT_EQ(d["box"][0], r.box.x);
    if (r.visible_pixels > 0) {
      ++visible;
      EXPECT_DOUBLE_EQ(d["distance_m"].get<double>(), r.distance_m);
    } else {
      EXPECT_TRUE(d["distance_m"].is_null());
    }
  }
  EXPECT_GT(visible, 0);
  const nlohmann::json plain_truth =
      SequenceFrameTruthToJson(k, plain.TimestampOf(k), plain.TravelledAt(k), without);
  EXPECT_FALSE(plain_truth.contains("defects"));
}

// With tilted_damper_share 1 every damper of the layout is turned by 10..25 deg, and nothing else
// of the sequence changes; the frames and their truth carry the tilt.
TEST(PowerLineSequence, TiltedDampersLeaveTheRestAlone) {
  PowerLineSequenceOptions o = FastSequence(13);
  const PowerLineSequence plain(o);
  o.tilted_damper_share = 1.0;
  const PowerLineSequence damaged(o);
  ASSERT_EQ(damaged.layout().size(), plain.layout().size());
  int dampers = 0;
  for (size_t i = 0; i < plain.layout().size(); ++i) {
    const SequenceLayoutEntry& e = damaged.layout()[i];
    EXPECT_EQ(e.type, plain.layout()[i].type);
    EXPECT_EQ(e.arc_m, plain.layout()[i].arc_m);
    EXPECT_EQ(plain.layout()[i].tilt_deg, 0);
    if (e.type == ObstacleType::kDamper) {
      ++dampers;
      EXPECT_GE(std::fabs(e.tilt_deg), 10);
      EXPECT_LE(std::fabs(e.tilt_deg), 25);
    } else {
      EXPECT_EQ(e.tilt_deg, 0);
    }
  }
  ASSERT_GT(dampers, 0);
  const PowerLineSceneOptions a = plain.FrameOptions(5), b = damaged.FrameOptions(5);
  EXPECT_EQ(a.conductor_pitch_rad, b.conductor_pitch_rad);
  EXPECT_EQ(a.sensor.noise_seed, b.sensor.noise_seed);
  ASSERT_EQ(a.obstacles.size(), b.obstacles.size());
  for (size_t i = 0; i < b.obstacles.size(); ++i) {
    EXPECT_EQ(b.obstacles[i].tilt_deg, damaged.layout()[i].tilt_deg);
  }
  const PowerLineScene scene = damaged.Render(0);
  const nlohmann::json truth =
      SequenceFrameTruthToJson(0, damaged.TimestampOf(0), damaged.TravelledAt(0), scene);
  for (size_t i = 0; i < scene.obstacles.size(); ++i) {
    EXPECT_EQ(truth["obstacles"][i].contains("tilt_deg"), damaged.layout()[i].tilt_deg != 0);
  }
}

TEST(PowerLineSequence, RejectsBadOptionsNamingTheField) {
  auto expect_rejected = [](auto change, const std::string& field) {
    PowerLineSequenceOptions o;
    change(o);
    try {
      const PowerLineSequence sequence(o);
      ADD_FAILURE() << "accepted " << field;
    } catch (const OptionError& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  expect_rejected([](auto& o) { o.speed_mps = 0; }, "speed_mps");
  expect_rejected([](auto& o) { o.fps = -1; }, "fps");
  expect_rejected([](auto& o) { o.end_gap_m = 7; }, "start_gap_m");
  expect_rejected([](auto& o) { o.num_obstacles = 9; }, "num_obstacles");
  expect_rejected([](auto& o) { o.num_defects = 7; }, "num_defects");
  expect_rejected([](auto& o) { o.num_defects = -1; }, "num_defects");
  expect_rejected([](auto& o) { o.tilted_damper_share = 1.5; }, "tilted_damper_share");
  expect_rejected(
      [](auto& o) {
        o.num_obstacles = 1;
        o.start_gap_m = 1.0;
        o.num_defects = 3;
      },
      "num_defects");
  expect_rejected([](auto& o) { o.max_spacing_m = 0.5; }, "max_spacing_m");
  expect_rejected([](auto& o) { o.bounce_m = 1; }, "bounce_m");
  expect_rejected([](auto& o) { o.scene.span_ahead_m = 12; }, "span_ahead_m");
}

}  // namespace
}  // namespace linesight::sim
