#include "linesight/server/chain_bench.h"

#include <gtest/gtest.h>

#include "linesight/core/error.h"
#include "linesight/core/option_test_util.h"
#include "linesight/sim/power_line_scene.h"

namespace linesight {
namespace {

TEST(ChainBenchOptions, DefaultsAreValidAndBoundariesRejected) {
  EXPECT_NO_THROW(ChainBenchOptions{}.Check());
  using testing::ExpectCheckRejects;
  ExpectCheckRejects<ChainBenchOptions>([](auto& o) { o.methods.clear(); });
  ExpectCheckRejects<ChainBenchOptions>([](auto& o) { o.warmup = -1; });
  ExpectCheckRejects<ChainBenchOptions>([](auto& o) { o.frames = 0; });
  ExpectCheckRejects<ChainBenchOptions>([](auto& o) { o.station.jpeg_quality = 0; });
}

// The chain on the still power-line scene: one row per method in order, every stage timed, the
// frame at least as long as its match, the ratio taken against the sgbm row.
TEST(ChainBench, StepsTheStationPerMethodAndReportsEveryStage) {
  sim::PowerLineSceneOptions scene_options;
  scene_options.sensor.supersampling = 1;
  const sim::PowerLineScene scene = sim::RenderPowerLineScene(scene_options);
  ChainBenchOptions options;
  options.methods = {"sgm:paths=4", "sgbm"};
  options.warmup = 1;
  options.frames = 2;
  options.station.pipeline.min_depth_m = 1.0;  // fewer disparities: a faster test
  options.station.pipeline.threads = 1;
  int told = 0;
  const ChainBenchReport report =
      RunChainBench(scene.left, scene.right, scene.calibration, "test scene", options,
                    [&](const ChainBenchRow&) { ++told; });
  EXPECT_EQ(told, 2);
  ASSERT_EQ(report.rows.size(), 2u);
  EXPECT_EQ(report.rows[0].method, "sgm:paths=4");
  EXPECT_EQ(report.image_size, scene.left.size());
  for (const ChainBenchRow& row : report.rows) {
    EXPECT_EQ(row.frames, 2);
    EXPECT_GT(row.searched_disparities, 10);
    EXPECT_GT(row.median.match, 0);
    EXPECT_GT(row.median.encode, 0);
    EXPECT_GE(row.frame_ms, row.median.match);
    EXPECT_NEAR(row.fps, 1000.0 / row.frame_ms, 1e-9);
    EXPECT_GT(row.match_mde_per_s, 0);
  }
  EXPECT_DOUBLE_EQ(report.rows[1].ratio_to_sgbm, 1.0);
  EXPECT_GT(report.rows[0].ratio_to_sgbm, 0);
  const nlohmann::json j = ChainBenchJson(report);
  EXPECT_EQ(j["rows"].size(), 2u);
  EXPECT_TRUE(j["rows"][0]["median_stage_ms"].contains("rectify"));
  EXPECT_NE(ChainBenchMarkdown(report).find("| sgbm |"), std::string::npos);
}

TEST(ChainBench, AnUnknownMethodIsAUsageError) {
  sim::PowerLineSceneOptions scene_options;
  scene_options.sensor.supersampling = 1;
  const sim::PowerLineScene scene = sim::RenderPowerLineScene(scene_options);
  ChainBenchOptions options;
  options.methods = {"nonsense"};
  EXPECT_THROW(RunChainBench(scene.left, scene.right, scene.calibration, "x", options), UsageError);
}

}  // namespace
}  // namespace linesight
