// Disparity error metrics as the benchmarks define them (DESIGN.md "Metrics").
#pragma once

#include <array>
#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

namespace linesight {

inline constexpr std::array<double, 4> kBadThresholds = {0.5, 1.0, 2.0, 4.0};

struct DisparityMetrics {
  int64_t evaluated = 0;  // pixels in the region with known ground truth
  int64_t estimated = 0;  // of those, pixels with a finite estimate
  double density = 0;     // estimated / evaluated, in percent
  // Dense variant (a missing estimate counts as an error of infinite size): bad-tau in percent of evaluated.
  std::array<double, 4> bad{};  // for kBadThresholds
  double d1 = 0;                // KITTI D1: |e| > 3 px and |e| > 5 % of d_gt, percent of evaluated
  // Sparse variant (only estimated pixels): bad-tau and D1 in percent of estimated.
  std::array<double, 4> bad_sparse{};
  double d1_sparse = 0;
  // Over estimated pixels only (a missing estimate has no finite error): mean |e| and RMSE in px.
  double avgerr = 0;
  double rmse = 0;

  nlohmann::json ToJson() const;
};

// Compares `disparity` (CV_32FC1, +inf = no estimate) with `ground_truth` (CV_32FC1, non-finite = unknown)
// over `mask` (CV_8UC1, non-zero = evaluate; empty = every pixel).
DisparityMetrics ComputeDisparityMetrics(const cv::Mat& disparity, const cv::Mat& ground_truth,
                                         const cv::Mat& mask = cv::Mat());

}  // namespace linesight
