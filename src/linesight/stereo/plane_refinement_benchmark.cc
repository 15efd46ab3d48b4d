// Cost of ISGM's refinement stages (its default options) at the MYNT S1030 resolution (752x480) on
// a synthetic scene of slanted planes with 15 % holes and 10 % mismatches. End-to-end throughput
// against OpenCV is `linesight bench`.
#include <benchmark/benchmark.h>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "linesight/core/disparity.h"
#include "linesight/stereo/isgm.h"
#include "linesight/stereo/plane_refinement.h"

namespace linesight {
namespace {

constexpr int kWidth = 752, kHeight = 480;

// Grey, as isgm segments it.
cv::Mat Image() {
  cv::RNG rng(1);
  cv::Mat image(kHeight, kWidth, CV_8UC1);
  rng.fill(image, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(image, image, cv::Size(9, 9), 3.0);
  return image;
}

cv::Mat Disparity() {
  cv::RNG rng(2);
  cv::Mat d(kHeight, kWidth, CV_32FC1);
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      float v = x < kWidth / 3 ? 20.0f + 0.02f * x : (y < kHeight / 2 ? 60.0f : 35.0f + 0.05f * y);
      const double u = rng.uniform(0.0, 1.0);
      if (u < 0.15)
        v = kInvalidDisparity;
      else if (u < 0.25)
        v += rng.uniform(-20.0f, 20.0f);
      d.at<float>(y, x) = v;
    }
  }
  return d;
}

void BM_SegmentSuperpixels(benchmark::State& state) {
  const cv::Mat image = Image();
  int n = 0;
  for (auto _ : state)
    benchmark::DoNotOptimize(
        SegmentSuperpixels(image, IsgmDefaultRefinementOptions().superpixels, &n));
  state.counters["segments"] = n;
}
BENCHMARK(BM_SegmentSuperpixels)->Unit(benchmark::kMillisecond);

void BM_RefineDisparityWithPlanes(benchmark::State& state) {
  const cv::Mat image = Image(), d = Disparity();
  PlaneRefinementStats stats;
  for (auto _ : state) {
    benchmark::DoNotOptimize(
        RefineDisparityWithPlanes(d, image, IsgmDefaultRefinementOptions(), &stats));
  }
  state.counters["superpixel_ms"] = stats.superpixel_ms;
  state.counters["plane_fit_ms"] = stats.plane_fit_ms;
  state.counters["fill_ms"] = stats.fill_ms;
}
BENCHMARK(BM_RefineDisparityWithPlanes)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace linesight
