#include "linesight/server/distance_tracker.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "linesight/core/error.h"

namespace linesight {
namespace {

TEST(DistanceTrackerOptions, DefaultsAreValidAndBoundsChecked) {
  EXPECT_NO_THROW(DistanceTrackerOptions().Check());
  DistanceTrackerOptions o;
  o.min_iou = 0;
  EXPECT_THROW(o.Check(), OptionError);
  o = {};
  o.acceleration_psd = 0;
  EXPECT_THROW(o.Check(), OptionError);
  o = {};
  o.max_rejections = 0;
  EXPECT_THROW(o.Check(), OptionError);
}

TEST(BoxIou, HandComputed) {
  EXPECT_DOUBLE_EQ(BoxIou({0, 0, 10, 10}, {0, 0, 10, 10}), 1.0);
  EXPECT_DOUBLE_EQ(BoxIou({0, 0, 10, 10}, {5, 0, 10, 10}), 50.0 / 150.0);
  EXPECT_DOUBLE_EQ(BoxIou({0, 0, 10, 10}, {20, 20, 5, 5}), 0.0);
}

// An obstacle approached at constant speed, measured with the sigma the ranging reports: the
// filtered distance must be closer to the truth than the raw measurements, its sigma must be
// smaller than theirs and still cover the truth, and the rate must come out as the speed.
TEST(DistanceTracker, ConstantApproachIsTrackedBetterThanSingleFrames) {
  DistanceTracker tracker;
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 1.0);
  const double speed = -0.5, dt = 0.1, sigma = 0.03;
  double raw_sq = 0, filtered_sq = 0;
  int n = 0, covered = 0;
  std::vector<TrackState> tracks;
  for (int i = 0; i < 80; ++i) {
    const double t = i * dt, truth = 6.0 + speed * t;
    const double z = truth + sigma * noise(rng);
    tracks = tracker.Update(t, {{"roi:0", {10, 10, 20, 20}, z, sigma}});
    ASSERT_EQ(tracks.size(), 1u);
    if (i >= 20) {  // after convergence
      raw_sq += (z - truth) * (z - truth);
      filtered_sq += (tracks[0].distance_m - truth) * (tracks[0].distance_m - truth);
      covered += std::abs(tracks[0].distance_m - truth) <= 2 * tracks[0].sigma_m;
      ++n;
    }
  }
  EXPECT_LT(std::sqrt(filtered_sq / n), 0.6 * std::sqrt(raw_sq / n));
  EXPECT_LT(tracks[0].sigma_m, sigma);
  EXPECT_GE(covered, n * 85 / 100);
  EXPECT_NEAR(tracks[0].rate_m_s, speed, 0.1);
  EXPECT_EQ(tracks[0].id, 1);
  EXPECT_EQ(tracks[0].updates, 80);
  EXPECT_EQ(tracks[0].key, "roi:0");
  EXPECT_TRUE(tracks[0].confirmed);
}

TEST(DistanceTracker, OutlierIsRejectedThenPersistentChangeRestarts) {
  DistanceTrackerOptions options;
  options.max_rejections = 3;
  DistanceTracker tracker(options);
  for (int i = 0; i < 10; ++i) tracker.Update(0.1 * i, {{"roi:0", {0, 0, 5, 5}, 3.0, 0.02}});
  auto tracks = tracker.Update(1.0, {{"roi:0", {0, 0, 5, 5}, 1.0, 0.02}});  // a wild reading
  ASSERT_EQ(tracks.size(), 1u);
  EXPECT_NEAR(tracks[0].distance_m, 3.0, 0.01);
  EXPECT_EQ(tracks[0].rejections, 1);
  tracker.Update(1.1, {{"roi:0", {0, 0, 5, 5}, 1.0, 0.02}});
  tracks = tracker.Update(1.2, {{"roi:0", {0, 0, 5, 5}, 1.0, 0.02}});  // third in a row: restart
  ASSERT_EQ(tracks.size(), 1u);
  EXPECT_NEAR(tracks[0].distance_m, 1.0, 1e-9);
  EXPECT_EQ(tracks[0].id, 1) << "a restarted track keeps its id";
  EXPECT_EQ(tracks[0].rejections, 3);
}

TEST(DistanceTracker, AutomaticDetectionsAssociateByBoxAndDropWhenMissing) {
  DistanceTrackerOptions options;
  options.max_missed_frames = 2;
  DistanceTracker tracker(options);
  auto tracks = tracker.Update(
      0.0, {{"", {100, 100, 20, 20}, 2.0, 0.02}, {"", {300, 100, 20, 20}, 4.0, 0.05}});
  ASSERT_EQ(tracks.size(), 2u);
  const int near_id = tracks[0].id, far_id = tracks[1].id;
  EXPECT_NE(near_id, far_id);
  // Next frame: both moved a little, listed in the other order.
  tracks = tracker.Update(
      0.1, {{"", {302, 101, 20, 20}, 4.01, 0.05}, {"", {101, 100, 20, 20}, 1.99, 0.02}});
  ASSERT_EQ(tracks.size(), 2u);
  EXPECT_EQ(tracks[0].id, near_id);
  EXPECT_EQ(tracks[1].id, far_id);
  EXPECT_EQ(tracks[0].updates, 2);
  EXPECT_FALSE(tracks[0].confirmed) << "automatic tracks are confirmed after 3 updates";
  // A detection elsewhere starts a new track; the unseen ones are dropped after 2 frames.
  tracker.Update(0.2, {{"", {500, 300, 10, 10}, 5.0, 0.1}});
  tracks = tracker.Update(0.3, {{"", {500, 300, 10, 10}, 5.0, 0.1}});
  ASSERT_EQ(tracks.size(), 1u);
  EXPECT_NE(tracks[0].id, near_id);
  EXPECT_NE(tracks[0].id, far_id);
}

TEST(DistanceTracker, RejectsInvalidMeasurements) {
  DistanceTracker tracker;
  EXPECT_THROW(tracker.Update(0, {{"roi:0", {0, 0, 1, 1}, 1.0, 0.0}}), InputError);
  EXPECT_THROW(tracker.Update(0, {{"roi:0", {0, 0, 1, 1}, NAN, 0.1}}), InputError);
}

}  // namespace
}  // namespace linesight
