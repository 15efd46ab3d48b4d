// Cost of the line stages on one 752x480 frame of the moving synthetic sequence (seed 3, frame
// 160: a clamp 1.2 m ahead, a damper and an insulator string farther on, a tower beside the line),
// on isgm's disparities of that frame: the conductor model alone, and the conductor model with
// the obstacles on it (their ranging and surface refinement included), with and without the
// widened-band search for far obstacles.
#include <optional>

#include <benchmark/benchmark.h>

#include "linesight/line/line_obstacles.h"
#include "linesight/line/line_test_util.h"
#include "linesight/sim/power_line_sequence.h"

namespace linesight {
namespace {

struct Frame {
  Frame() {
    const sim::PowerLineScene scene = sim::PowerLineSequence(testing::FastSequence(3)).Render(160);
    pipeline.emplace(scene.calibration, RangingPipelineOptions{});
    frame = pipeline->Process(scene.left, scene.right);
  }
  std::optional<RangingPipeline> pipeline;
  RangingFrame frame;
};

const Frame& TheFrame() {
  static const Frame frame;
  return frame;
}

void BM_FitConductor(benchmark::State& state) {
  const Frame& f = TheFrame();
  for (auto _ : state) {
    benchmark::DoNotOptimize(FitConductor(f.frame.disparity, f.pipeline->geometry(), {}));
  }
}
BENCHMARK(BM_FitConductor)->Unit(benchmark::kMillisecond);

// Argument 1: as configured; 0: without the widened-band search for far obstacles (its cost).
void BM_FindLineObstacles(benchmark::State& state) {
  const Frame& f = TheFrame();
  LineObstacleOptions options;
  if (state.range(0) == 0) options.min_widening_px = 0;
  std::size_t found = 0;
  for (auto _ : state) {
    const LineObstacles result = FindLineObstacles(*f.pipeline, f.frame, options);
    found = result.obstacles.size();
    benchmark::DoNotOptimize(found);
  }
  state.counters["obstacles"] = static_cast<double>(found);
}
BENCHMARK(BM_FindLineObstacles)->Arg(1)->Arg(0)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace linesight
