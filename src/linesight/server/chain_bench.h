// The live chain's throughput (`linesight bench --chain`): what `linesight serve` does per frame —
// grab, rectify, match, find and range, inspect the conductor (line finder), the calibration-health
// measure on its frames, encode the page's images — stepped on one pair held in memory, per method
// in the same run, with each stage's median time, frames per second, the matcher's MDE/s, minor
// page faults per frame (first touches of fresh memory: large buffers allocated per frame show
// here) and the process's peak memory; then the same through the station's loop with
// grabbing-and-matching overlapped with ranging (frame interval, rate, latency). Ratios are against
// the row of OpenCV's StereoSGBM ("sgbm") run through the same chain.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "linesight/io/stereo_calibration.h"
#include "linesight/server/base_station.h"

namespace linesight {

struct ChainBenchOptions {
  // Matchers run through the chain, each NAME[:key=value...] as in `bench --methods`; the ratios
  // are against the row named "sgbm" (0 when it is not run).
  std::vector<std::string> methods = {"isgm", "sgm", "sgbm"};
  int warmup = 3;   // frames stepped before timing (discarded): buffers, caches, thread pools
  int frames = 20;  // timed frames per method (>= 1)
  // The station's settings (working range, finder, threads, ...); its method is set per row.
  BaseStationOptions station;

  void Check() const;
};

struct ChainBenchRow {
  std::string method;
  int frames = 0;
  int searched_disparities = 0;
  StageTimes median;                 // per stage, median over the timed frames (ms)
  double frame_ms = 0;               // median wall time of one whole step (ms)
  double fps = 0;                    // 1000 / frame_ms
  double match_mde_per_s = 0;        // W·H·searched disparities / median match time
  double page_faults_per_frame = 0;  // minor faults per timed frame (mean)
  double ratio_to_sgbm = 0;          // sgbm's frame_ms / this row's (0 without an sgbm row)
  // The same frames through the station's own loop with its two stages overlapped
  // (BaseStationOptions::overlap): median time between publications, its rate, and the median
  // end-to-end latency (pair in hand to result published).
  double overlapped_frame_ms = 0;
  double overlapped_fps = 0;
  double overlapped_latency_ms = 0;
  double overlapped_ratio_to_sgbm = 0;  // sgbm's overlapped_frame_ms / this row's
};

struct ChainBenchReport {
  std::string cpu;
  int hardware_threads = 0;
  cv::Size image_size;
  std::string input;       // what was stepped
  std::string finder;      // line or regions
  double peak_rss_mb = 0;  // VmHWM of the process after every row (MiB)
  int warmup = 0;
  std::vector<ChainBenchRow> rows;
};

// Steps a BaseStation over the pair for each method. `progress` (may be empty) is told each row.
ChainBenchReport RunChainBench(const cv::Mat& left, const cv::Mat& right,
                               const StereoCalibration& calibration, const std::string& input,
                               const ChainBenchOptions& options,
                               const std::function<void(const ChainBenchRow&)>& progress = {});

std::string ChainBenchMarkdown(const ChainBenchReport& report);
nlohmann::json ChainBenchJson(const ChainBenchReport& report);

}  // namespace linesight
