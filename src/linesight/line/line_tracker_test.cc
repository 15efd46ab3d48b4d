#include "linesight/line/line_tracker.h"

#include <random>

#include <gtest/gtest.h>

#include "linesight/core/error.h"

namespace linesight {
namespace {

LineObstacle Reading(LineObstacleType type, double arc, double confidence = 0.8) {
  LineObstacle o;
  o.type = type;
  o.arc_m = arc;
  o.arc_sigma_m = 0.01 * arc;
  o.distance_m = 0.97 * arc;
  o.sigma_m = 0.01 * arc;
  o.confidence = confidence;
  return o;
}

TEST(LineTrackerOptionsTest, DefaultsAreValidAndBoundsAreChecked) {
  EXPECT_NO_THROW(LineTrackerOptions{}.Check());
  EXPECT_THROW((LineTrackerOptions{.gate_m = 0}.Check()), OptionError);
  EXPECT_THROW((LineTrackerOptions{.min_hits = 0}.Check()), OptionError);
  LineTracker tracker;
  tracker.Update(1.0, {});
  EXPECT_THROW(tracker.Update(1.0, {}), OptionError);  // time must move on
}

// A robot at 0.3 m/s, 30 fps, toward a clamp at 2 m and a damper at 2.6 m along the line; arc
// readings with 1 % noise, the damper missed in a stretch of frames and typed "clamp" in some,
// one spurious reading. One track per obstacle, ids kept, the rate and the time to reach right.
TEST(LineTrackerTest, OneTrackPerObstacleWithRateAndTimeToReach) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0.0, 0.01);
  LineTracker tracker;
  const double speed = 0.3, fps = 30.0;
  std::vector<LineTrack> tracks;
  int clamp_id = 0, damper_id = 0;
  for (int f = 0; f < 90; ++f) {
    const double t = f / fps, clamp = 2.0 - speed * t, damper = 2.6 - speed * t;
    std::vector<LineObstacle> frame;
    frame.push_back(Reading(LineObstacleType::kClamp, clamp * (1 + noise(rng))));
    if (f < 30 || f > 45) {
      frame.push_back(Reading(f % 4 == 0 ? LineObstacleType::kClamp : LineObstacleType::kDamper,
                              damper * (1 + noise(rng))));
    }
    if (f == 50) frame.push_back(Reading(LineObstacleType::kInsulator, 4.0, 0.3));  // spurious
    tracks = tracker.Update(t, frame);
    if (f >= 2 && f != 50) {
      ASSERT_EQ(tracks.size(), 2u) << "frame " << f;
      if (clamp_id == 0) {
        clamp_id = tracks[0].id;
        damper_id = tracks[1].id;
      }
      EXPECT_EQ(tracks[0].id, clamp_id) << "frame " << f;
      EXPECT_EQ(tracks[1].id, damper_id) << "frame " << f;
    }
  }
  ASSERT_EQ(tracks.size(), 2u);
  const double t = 89 / fps;
  EXPECT_EQ(tracks[0].type, LineObstacleType::kClamp);
  EXPECT_EQ(tracks[1].type, LineObstacleType::kDamper);
  EXPECT_NEAR(tracks[0].arc_m, 2.0 - speed * t, 0.02);
  EXPECT_NEAR(tracks[1].arc_m, 2.6 - speed * t, 0.03);
  for (const LineTrack& k : tracks) {
    EXPECT_NEAR(k.approach_mps, speed, 0.05 * speed);
    EXPECT_NEAR(k.time_to_reach_s, k.arc_m / speed, 0.06 * k.arc_m / speed);
    EXPECT_GT(k.arc_sigma_m, 0.0);
  }
}

// A track without readings coasts on its rate, then goes; an obstacle passed is dropped.
TEST(LineTrackerTest, CoastsThenDropsAndForgetsWhatIsPassed) {
  LineTracker tracker({.max_coast_s = 0.5, .min_hits = 1});
  for (int f = 0; f < 10; ++f)
    tracker.Update(f * 0.1, {Reading(LineObstacleType::kClamp, 1 - 0.03 * f)});
  std::vector<LineTrack> tracks = tracker.Update(1.2, {});
  ASSERT_EQ(tracks.size(), 1u);
  EXPECT_NEAR(tracks[0].arc_m, 1 - 0.03 * 12, 0.01);  // coasted at 0.3 m/s
  EXPECT_TRUE(tracker.Update(1.5, {}).empty());       // 0.6 s without a reading
  LineTracker near({.min_hits = 1});
  for (int f = 0; f < 5; ++f)
    near.Update(f * 0.1, {Reading(LineObstacleType::kClamp, 0.1 - 0.1 * f)});
  EXPECT_TRUE(near.Tracks().empty());  // behind the robot
}

}  // namespace
}  // namespace linesight
