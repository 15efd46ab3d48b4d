// Naive scalar references of the SGM stages (CONVENTIONS.md §7), written straight from the
// definitions in sgm_stages.h with no optimisation: plain loops, no padding, no SIMD. Test-only
// (compiled into linesight_stereo_test): sgm_reference_test.cc requires every SIMD kernel and the
// whole SgmMatcher to agree with them exactly.
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "linesight/stereo/sgm.h"
#include "linesight/stereo/sgm_stages.h"

namespace linesight::reference {

// Census codes of every pixel of `gray` (CV_8UC1), width*height row-major (CensusTransform).
std::vector<uint64_t> Census(const cv::Mat& gray, int window_width, int window_height);

// Birchfield–Tomasi dissimilarity in half grey levels between left[x] and right[xr], from the
// definition (rows of `width` pixels).
int BirchfieldTomasi2(const uint8_t* left, const uint8_t* right, int width, int x, int xr);

// Matching costs C(x, y, k) of every pixel (MatchingCostRow): [y][x][k], num_disparities lanes.
std::vector<uint16_t> MatchingCost(const detail::CostInput& input);

// Sums S(x, y, k) over the paths of the recurrence in AggregatePaths, one direction at a time:
// [y][x][k], num_disparities lanes. `cost` as MatchingCost returns it.
std::vector<uint32_t> AggregatePaths(const detail::AggregationInput& input,
                                     const std::vector<uint16_t>& cost);

// Winner-takes-all of every row of `sum` (WinnerTakesAllRow), width*height row-major each.
struct WinnerTakesAllResult {
  std::vector<int> best, best_cost, second, right_best;
};
WinnerTakesAllResult WinnerTakesAll(const std::vector<uint32_t>& sum, int width, int height,
                                    int num_disparities, int min_disparity);

// The fixed-point disparity (CV_16SC1, kSgmSubpixelScale, kSgmInvalidFixed = invalid) that
// SgmMatcher derives from the sums and winners: pixels without a full disparity range, the
// uniqueness test, the left-right check and the subpixel offset of `options`.
cv::Mat SelectDisparities(const std::vector<uint32_t>& sum, const WinnerTakesAllResult& winners,
                          int width, int height, const SgmOptions& options);

// Lower median of the valid values of each valid pixel's 3×3 window (MedianValid3x3): CV_16SC1,
// kSgmInvalidFixed = invalid.
cv::Mat MedianValid3x3(const cv::Mat& src);

}  // namespace linesight::reference
