// End-to-end throughput of dense matchers measured in the same run on the same images (`linesight
// bench`): our sgm / isgm against OpenCV's StereoSGBM (MODE_SGBM_3WAY and MODE_HH). Each (method,
// size) runs in a forked child process so that its peak resident memory (VmHWM) is its own and
// OpenCV's thread pool starts fresh; the child reports back through a pipe.
#pragma once

#include <functional>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

namespace linesight {

struct BenchSize {
  int width = 752;            // px
  int height = 480;           // px
  int num_disparities = 128;  // disparities searched
};

// "isgm:paths=8:p1=10" -> method "isgm", params {paths: 8, p1: 10}; throws UsageError for an
// item that is not key=value and for a key given twice.
void SplitBenchMethod(const std::string& spec, std::string* method,
                      std::map<std::string, std::string>* params);

// "752x480x128" -> {752, 480, 128}; throws UsageError otherwise.
BenchSize ParseBenchSize(const std::string& text);

struct BenchOptions {
  // Image sizes and disparity counts: the MYNT S1030 resolution at 128 and 192 disparities, KITTI
  // at 128.
  std::vector<BenchSize> sizes = {{752, 480, 128}, {752, 480, 192}, {1242, 375, 128}};
  // Methods: any CreateMatcher name, plus "sgbm-3way" and "sgbm-hh" (OpenCV StereoSGBM in that
  // mode), optionally with the method's --param settings: NAME[:key=value...] (e.g.
  // "isgm:paths=8", to compare settings in one run). A method the factory does not know (e.g.
  // isgm before it exists) is reported as skipped; bad settings throw UsageError. The ratios are
  // taken against the row named exactly "sgbm-3way".
  std::vector<std::string> methods = {"sgm", "isgm", "sgbm-3way", "sgbm-hh"};
  int runs = 7;  // timed runs per (method, size) and round
  // Rounds over the method list per size (method A, B, C, A, B, C, ...): load drift on a shared
  // machine then hits every method alike. The median is over all rounds' runs; the ratio to
  // SGBM_3WAY is also reported per round (its range).
  int rounds = 3;
  int warmup = 1;   // untimed runs before them (discarded)
  int threads = 0;  // worker threads for every method; 0 = all hardware threads
  // Optional input pair, resized to each size; empty = seeded synthetic textured pair.
  cv::Mat left, right;

  void Check() const;
};

struct BenchRow {
  std::string method;
  BenchSize size;
  bool skipped = false;
  std::string note;        // why it was skipped, or the error
  double median_ms = 0;    // median wall time of one Compute (ms)
  double min_ms = 0;       // fastest run (ms)
  double fps = 0;          // 1000 / median_ms
  double mde_per_s = 0;    // W·H·D·fps / 1e6
  double peak_rss_mb = 0;  // VmHWM of the child process (MiB): everything resident at its peak
  double peak_added_mb =
      0;  // VmHWM minus the RSS the child started with (MiB): what the method allocated
  double density = 0;        // % of pixels with an estimate in the last run
  double ratio_to_3way = 0;  // MDE/s relative to sgbm-3way at the same size (0 if not measured)
  double ratio_low = 0, ratio_high = 0;  // smallest and largest per-round ratio
  // Median over the rounds of the ratio within each round (the methods of a round run back to
  // back): less sensitive than ratio_to_3way to the machine's speed drifting between rounds.
  double ratio_paired = 0;
  std::vector<double> round_median_ms;  // median of each round's runs
};

struct BenchReport {
  std::string cpu;  // /proc/cpuinfo model name
  int hardware_threads = 0;
  int threads = 0;          // as used by the methods
  std::string simd_target;  // Highway target of the sgm kernels
  std::string opencv_version;
  std::string input;  // "synthetic" or the input size
  int runs = 0, warmup = 0, rounds = 0;
  std::vector<BenchRow> rows;
};

// Runs every method at every size. `progress` (may be empty) is told each finished row.
BenchReport RunThroughputBench(const BenchOptions& options,
                               const std::function<void(const BenchRow&)>& progress = {});

std::string BenchMarkdown(const BenchReport& report);
nlohmann::json BenchJson(const BenchReport& report);

}  // namespace linesight
