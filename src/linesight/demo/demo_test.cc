#include "linesight/demo/demo.h"

#include <gtest/gtest.h>

#include "linesight/core/error.h"
#include "linesight/core/option_test_util.h"
#include "linesight/io/json_io.h"
#include "linesight/ranging/ranging_settings.h"

namespace linesight {
namespace {
namespace fs = std::filesystem;

TEST(DemoOptions, DefaultsAreValid) { EXPECT_NO_THROW(DemoOptions().Check()); }

TEST(DemoOptions, RejectsBadValues) {
  using testing::ExpectCheckRejects;
  ExpectCheckRejects<DemoOptions>([](auto& o) { o.board_views = 2; });
  ExpectCheckRejects<DemoOptions>([](auto& o) { o.min_depth_m = 7; });
  ExpectCheckRejects<DemoOptions, UsageError>([](auto& o) { o.calibration_method = "magic"; });
}

// The whole chain with the true calibration and one obstacle: the measured distance must be within
// 2 % and every output file must exist. (The full demo with calibration is the README's main
// command.)
TEST(RunDemo, RangesAnObstacleWithTheTrueCalibration) {
  DemoOptions o;
  o.out_dir = fs::temp_directory_path() / ("linesight_demo_test_" + std::to_string(::getpid()));
  o.use_true_calibration = true;
  o.obstacles = {{sim::ObstacleType::kDamper, 2.0, 0}};
  const DemoReport report = RunDemo(o);
  ASSERT_EQ(report.rows.size(), 1u);
  ASSERT_TRUE(report.rows[0].measured) << report.rows[0].reason;
  EXPECT_NEAR(report.rows[0].distance_m, report.rows[0].true_distance_m,
              0.02 * report.rows[0].true_distance_m);
  EXPECT_GT(report.rows[0].sigma_m, 0);
  for (const char* f : {"stereo.yml", "left.png", "disparity.png", "disparity.pfm", "cloud.ply",
                        "report.json", "rectified_left_ranged.png"}) {
    EXPECT_TRUE(fs::exists(o.out_dir / f)) << f;
  }
  const nlohmann::json written = ReadJson(o.out_dir / "report.json");
  EXPECT_EQ(written["obstacles"].size(), 1u);
  EXPECT_EQ(written["ranging_settings"].size(), RangingSettingsTable().rows().size());
  fs::remove_all(o.out_dir);
}

}  // namespace
}  // namespace linesight
