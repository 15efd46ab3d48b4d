// Per-kernel microbenchmarks of the SGM pipeline (CONVENTIONS.md §12); end-to-end throughput
// against OpenCV is `linesight bench`. Arguments: width, height, disparities. Items processed =
// W·H·D disparity evaluations.
#include <benchmark/benchmark.h>
#include <opencv2/core.hpp>

#include "linesight/stereo/sgm.h"
#include "linesight/stereo/sgm_stages.h"

namespace linesight {
namespace {

struct Fixture {
  cv::Mat left, right;
  detail::AlignedVector<uint64_t> census_left, census_right;
  detail::AggregationInput input;

  Fixture(int w, int h, int num) {
    cv::RNG rng(1);
    left.create(h, w, CV_8UC1);
    rng.fill(left, cv::RNG::UNIFORM, 0, 256);
    right.create(h, w, CV_8UC1);
    rng.fill(right, cv::RNG::UNIFORM, 0, 256);
    census_left.resize(static_cast<size_t>(w) * h);
    census_right.resize(static_cast<size_t>(w) * h);
    detail::CensusTransform(left, 9, 7, 0, h, census_left.data());
    detail::CensusTransform(right, 9, 7, 0, h, census_right.data());
    input.cost.width = w;
    input.cost.height = h;
    input.cost.num_disparities = num;
    input.cost.census_bits = 62;
    input.cost.census_left = census_left.data();
    input.cost.census_right = census_right.data();
    input.cost.gray_left = left.ptr<uint8_t>();
    input.cost.gray_right = right.ptr<uint8_t>();
  }
};

void SetItems(benchmark::State& state) {
  state.SetItemsProcessed(state.iterations() * state.range(0) * state.range(1) * state.range(2));
  state.SetLabel(SgmSimdTarget());
}

void BM_Census(benchmark::State& state) {
  Fixture f(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)), 1);
  for (auto _ : state) {
    detail::CensusTransform(f.left, 9, 7, 0, f.left.rows, f.census_left.data());
    benchmark::DoNotOptimize(f.census_left.data());
  }
  state.SetItemsProcessed(state.iterations() * state.range(0) * state.range(1));
  state.SetLabel(SgmSimdTarget());
}
BENCHMARK(BM_Census)->Args({752, 480, 1})->Unit(benchmark::kMillisecond);

void BM_MatchingCost(benchmark::State& state) {
  Fixture f(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)),
            static_cast<int>(state.range(2)));
  std::vector<uint16_t> row(static_cast<size_t>(f.input.cost.width) *
                            detail::PaddedDisparities(f.input.cost.num_disparities));
  for (auto _ : state) {
    for (int y = 0; y < f.input.cost.height; ++y)
      detail::MatchingCostRow(f.input.cost, y, row.data());
    benchmark::DoNotOptimize(row.data());
  }
  SetItems(state);
}
BENCHMARK(BM_MatchingCost)->Args({752, 480, 128})->Unit(benchmark::kMillisecond);

void BM_AggregatePaths(benchmark::State& state) {
  Fixture f(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)),
            static_cast<int>(state.range(2)));
  f.input.num_paths = static_cast<int>(state.range(3));
  detail::SumVolume sum;
  detail::SweepScratch forward, backward;
  for (auto _ : state) {
    detail::AggregatePaths(f.input, static_cast<int>(state.range(4)), &sum, &forward, &backward,
                           [](int, const uint16_t* row) { benchmark::DoNotOptimize(row); });
  }
  SetItems(state);
}
BENCHMARK(BM_AggregatePaths)
    ->Args({752, 480, 128, 8, 1})
    ->Args({752, 8, 128, 8, 1})
    ->Args({752, 480, 128, 8, 2})
    ->Args({752, 480, 128, 4, 2})
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

void BM_WinnerTakesAll(benchmark::State& state) {
  const int w = static_cast<int>(state.range(0)), h = static_cast<int>(state.range(1));
  const int num = static_cast<int>(state.range(2));
  Fixture f(w, h, num);
  detail::SumVolume partial;
  detail::SweepScratch forward, backward;
  detail::AlignedVector<uint16_t> sum(static_cast<size_t>(w) * h * detail::PaddedDisparities(num));
  const size_t row_lanes = static_cast<size_t>(w) * detail::PaddedDisparities(num);
  detail::AggregatePaths(
      f.input, 2, &partial, &forward, &backward, [&](int y, const uint16_t* row) {
        std::copy(row, row + row_lanes, sum.begin() + static_cast<ptrdiff_t>(y * row_lanes));
      });
  std::vector<int16_t> best(w), right_best(w);
  std::vector<uint16_t> best_cost(w), second(w), scratch(detail::WtaScratchSize(w, num));
  // In the matcher each row is finished right after the aggregation wrote it (in cache): cycle over
  // a few rows instead of streaming the whole volume from memory.
  constexpr int kCachedRows = 4;
  for (auto _ : state) {
    for (int y = 0; y < h; ++y) {
      detail::WinnerTakesAllRow(sum.data() + (y % kCachedRows) * row_lanes, w, num, 0,
                                {best.data(), best_cost.data(), second.data(), right_best.data()},
                                scratch.data());
    }
    benchmark::DoNotOptimize(best.data());
  }
  SetItems(state);
}
BENCHMARK(BM_WinnerTakesAll)->Args({752, 480, 128})->Unit(benchmark::kMillisecond);

void BM_SgmEndToEnd(benchmark::State& state) {
  const int w = static_cast<int>(state.range(0)), h = static_cast<int>(state.range(1));
  Fixture f(w, h, 1);
  SgmOptions o;
  o.num_disparities = static_cast<int>(state.range(2));
  SgmMatcher matcher(o);
  for (auto _ : state) benchmark::DoNotOptimize(matcher.Compute(f.left, f.right).disparity.data);
  SetItems(state);
}
BENCHMARK(BM_SgmEndToEnd)->Args({752, 480, 128})->UseRealTime()->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace linesight

namespace linesight {
namespace {

// OpenCV baselines at the same size, for orientation (the official comparison is `linesight
// bench`).
void BM_OpenCvSgbm(benchmark::State& state) {
  const int w = static_cast<int>(state.range(0)), h = static_cast<int>(state.range(1));
  Fixture f(w, h, 1);
  MatcherOptions options;
  options.num_disparities = static_cast<int>(state.range(2));
  options.params["mode"] = state.range(3) == 0 ? "3way" : "hh";
  auto matcher = CreateMatcher("sgbm", options);
  for (auto _ : state) benchmark::DoNotOptimize(matcher->Compute(f.left, f.right).disparity.data);
  SetItems(state);
}
BENCHMARK(BM_OpenCvSgbm)->Args({752, 480, 128, 0})->UseRealTime()->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace linesight
