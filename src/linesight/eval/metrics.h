// Disparity error metrics as the benchmarks define them (DESIGN.md "Metrics").
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

namespace linesight {

inline constexpr std::array<double, 4> kBadThresholds = {0.5, 1.0, 2.0, 4.0};

struct DisparityMetrics {
  int64_t evaluated = 0;  // pixels in the region with known ground truth
  int64_t estimated = 0;  // of those, pixels with a finite estimate
  double density = 0;     // estimated / evaluated, in percent
  // Dense variant (a missing estimate counts as an error of infinite size): bad-tau in percent of
  // evaluated.
  std::array<double, 4> bad{};  // for kBadThresholds
  double d1 = 0;                // KITTI D1: |e| > 3 px and |e| > 5 % of d_gt, percent of evaluated
  // Sparse variant (only estimated pixels): bad-tau and D1 in percent of estimated.
  std::array<double, 4> bad_sparse{};
  double d1_sparse = 0;
  // Over estimated pixels only (a missing estimate has no finite error): mean |e| and RMSE in px.
  double avgerr = 0;
  double rmse = 0;

  // Keys: evaluated, estimated, density, bad_0.5, bad_1, bad_2, bad_4, d1, bad_0.5_sparse,
  // bad_1_sparse, bad_2_sparse, bad_4_sparse, d1_sparse, avgerr, rmse (percentages in percent,
  // errors in px).
  nlohmann::json ToJson() const;
  // Inverse of ToJson; throws nlohmann::json::exception when a key is missing or has the wrong
  // type.
  static DisparityMetrics FromJson(const nlohmann::json& json);
};

// Compares `disparity` (CV_32FC1, non-finite = no estimate) with `ground_truth` (CV_32FC1,
// non-finite = unknown) over `mask` (CV_8UC1, non-zero = evaluate; empty = every pixel). Errors are
// e = |d - d_gt| in double precision; a pixel is bad-tau when e > tau (e == tau is good) and D1
// when e > 3 and e > 0.05 * |d_gt|. Every ratio whose denominator is zero (no evaluated / no
// estimated pixel) is reported as 0; `evaluated` and `estimated` tell these cases apart. Throws
// InputError when types or sizes do not match.
DisparityMetrics ComputeDisparityMetrics(const cv::Mat& disparity, const cv::Mat& ground_truth,
                                         const cv::Mat& mask = cv::Mat());

// ComputeDisparityMetrics over each named region ("nonocc", "all", "disc", ... as in
// StereoScene::masks).
std::map<std::string, DisparityMetrics> ComputeRegionMetrics(
    const cv::Mat& disparity, const cv::Mat& ground_truth,
    const std::map<std::string, cv::Mat>& masks);

// JSON key of a bad-tau figure: "bad_0.5", "bad_1", "bad_2", "bad_4" (+ "_sparse" for the sparse
// variant).
std::string BadKey(double threshold, bool sparse = false);

}  // namespace linesight
