// Cost of the line stages on one 752x480 frame of the moving synthetic sequence (seed 3, frame
// 160: a clamp 1.2 m ahead, a damper and an insulator string farther on, a tower beside the line),
// on isgm's disparities of that frame: the conductor model alone, and the conductor model with
// the obstacles on it (their ranging and surface refinement included), with and without the
// widened-band search for far obstacles; the conductor's inspection (its radius profile, the
// faults on it, the dampers' roll), and the sweep for thin structures at the line's depth alone.
#include <algorithm>
#include <optional>

#include <benchmark/benchmark.h>

#include "linesight/line/conductor_faults.h"
#include "linesight/line/line_obstacles.h"
#include "linesight/line/line_test_util.h"
#include "linesight/line/thin_attachments.h"
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

void BM_InspectConductor(benchmark::State& state) {
  const Frame& f = TheFrame();
  const LineObstacles line = FindLineObstacles(*f.pipeline, f.frame, {});
  std::size_t faults = 0;
  for (auto _ : state) {
    const ConductorInspection inspection =
        InspectConductor(f.frame.left_rectified, f.frame.right_rectified, f.frame.checked_disparity,
                         line, f.pipeline->geometry(), {});
    faults = inspection.faults.size();
    benchmark::DoNotOptimize(faults);
  }
  state.counters["faults"] = static_cast<double>(faults);
}
BENCHMARK(BM_InspectConductor)->Unit(benchmark::kMillisecond);

// The sweep over the inspected stretch of the line (the images' conversion to float included).
void BM_FindThinAttachments(benchmark::State& state) {
  const Frame& f = TheFrame();
  const LineObstacles line = FindLineObstacles(*f.pipeline, f.frame, {});
  const ConductorInspection inspection =
      InspectConductor(f.frame.left_rectified, f.frame.right_rectified, f.frame.checked_disparity,
                       line, f.pipeline->geometry(), {});
  if (inspection.profile.empty()) {
    state.SkipWithError("no inspected stretch of the line");
    return;
  }
  double tau_from = inspection.profile.front().tau, tau_to = tau_from;
  for (const RadiusSample& s : inspection.profile) {
    tau_from = std::min(tau_from, s.tau);
    tau_to = std::max(tau_to, s.tau);
  }
  std::size_t found = 0;
  for (auto _ : state) {
    cv::Mat left, right;
    f.frame.left_rectified.convertTo(left, CV_32F);
    f.frame.right_rectified.convertTo(right, CV_32F);
    found = FindThinAttachments(left, right, f.frame.checked_disparity, line.conductor.line,
                                f.pipeline->geometry(), inspection.radius_m, tau_from, tau_to, {})
                .size();
    benchmark::DoNotOptimize(found);
  }
  state.counters["structures"] = static_cast<double>(found);
}
BENCHMARK(BM_FindThinAttachments)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace linesight
