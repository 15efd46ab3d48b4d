// The stages of SgmMatcher as free functions over plain buffers (CONVENTIONS.md §4). The SIMD
// kernels are compiled for every Highway target and dispatched at run time, one file per stage:
// sgm_census.cc, sgm_matching_cost.cc, sgm_aggregation.cc, sgm_winner_takes_all.cc and
// sgm_median.cc; sgm_reference.h holds a naive scalar reference of each, and
// sgm_reference_test.cc checks that they agree exactly.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <new>
#include <opencv2/core.hpp>

namespace linesight::detail {

// Disparity lanes are padded to a multiple of this (the widest vector: 64 uint8 = 64 bytes) so
// every SIMD target sees the same memory layout.
inline constexpr int kSgmLaneAlign = 64;
// Path costs of padding lanes and of the guards around each disparity vector: large enough never to
// win a minimum (path costs stay below kSgmMaxPathCost), small enough that adding P1 / P2 does not
// saturate.
inline constexpr uint16_t kSgmPathSentinel = 0x7FFF;
// Upper bound on matching cost + P2, which keeps every path cost below 4096 and the 8-path sum
// below 32768.
inline constexpr int kSgmMaxPathCost = 4000;
// Invalid value of the fixed-point disparity (int16, scale kSgmSubpixelScale) used for
// cv::filterSpeckles.
inline constexpr int16_t kSgmInvalidFixed = INT16_MIN;

inline int PaddedDisparities(int num_disparities) {
  return (num_disparities + kSgmLaneAlign - 1) / kSgmLaneAlign * kSgmLaneAlign;
}

// 64-byte aligned allocation for vectors that SIMD kernels stream through. Blocks of 4 MiB and
// more (the cost and sum volumes) are aligned to 2 MiB and advised to use transparent huge pages:
// a one-shot run touches each page of its ~100 MB of volumes once, and 4 KiB pages cost it ~25k
// page faults (a third of `linesight disparity`'s time at 752x480x128); 2 MiB pages ~50.
void* AllocateVolume(size_t bytes);
void FreeVolume(void* p, size_t bytes);

template <typename T>
struct CacheAlignedAllocator {
  using value_type = T;
  CacheAlignedAllocator() = default;
  template <typename U>
  CacheAlignedAllocator(const CacheAlignedAllocator<U>&) {}  // NOLINT(google-explicit-constructor)
  T* allocate(size_t n) { return static_cast<T*>(AllocateVolume(n * sizeof(T))); }
  void deallocate(T* p, size_t n) { FreeVolume(p, n * sizeof(T)); }
  template <typename U>
  bool operator==(const CacheAlignedAllocator<U>&) const {
    return true;
  }
};
template <typename T>
using AlignedVector = std::vector<T, CacheAlignedAllocator<T>>;

// ---------------------------------------------------------------------------------------------------------
// Census transform. Bit b of a pixel's code is 1 when the b-th window neighbour (row-major order
// over the window, centre skipped) is darker than the centre. Neighbours outside the image take the
// value of the nearest border pixel. Writes rows [row_begin, row_end) of `codes` (width*height,
// row-major).
void CensusTransform(const cv::Mat& gray, int window_width, int window_height, int row_begin,
                     int row_end, uint64_t* codes);

// ---------------------------------------------------------------------------------------------------------
// Matching cost C(x, y, k) for disparity d = min_disparity + k, k in [0, num_disparities):
//   C = popcount(census_left(x) ^ census_right(x - d)) + (bt_weight * min(BT2, 2 * bt_truncation))
//   / 16
// where BT2 is the Birchfield–Tomasi dissimilarity in half grey levels. When x - d falls outside
// the right image C = MaxMatchingCost(). Lanes k >= num_disparities are unspecified.
struct CostInput {
  int width = 0;
  int height = 0;
  int min_disparity = 0;
  int num_disparities = 0;
  int census_bits = 0;  // census_width * census_height - 1
  int bt_weight = 0;
  int bt_truncation = 0;
  const uint64_t* census_left = nullptr;   // width*height
  const uint64_t* census_right = nullptr;  // width*height
  const uint8_t* gray_left = nullptr;      // width*height, continuous
  const uint8_t* gray_right = nullptr;     // width*height, continuous
};
int MaxMatchingCost(const CostInput& input);
// Costs of row y into `out` (width * PaddedDisparities(num_disparities) uint16, pixel-major).
void MatchingCostRow(const CostInput& input, int y, uint16_t* out);

// ---------------------------------------------------------------------------------------------------------
// Path aggregation. For each path direction r:
//   L_r(p, k) = C(p, k) + min(L_r(p-r, k), L_r(p-r, k±1) + P1, min_i L_r(p-r, i) + P2'(p, r)) -
//   min_i L_r(p-r, i)
// with L_r(p, k) = C(p, k) for the first pixel of a path, and
//   P2'(p, r) = max(P1 + 1, P2 * alpha / (alpha + |I(p) - I(p-r)|))   (P2' = P2 when alpha = 0).
// Sum S(x, y, k) = sum over paths of L_r. 4 paths: (±1, 0), (0, ±1); 8 paths add the four
// diagonals.
struct AggregationInput {
  CostInput cost;
  int num_paths = 8;
  int p1 = 10;
  int p2 = 120;
  int p2_gradient_alpha = 0;
};

// Partial sums of the sweep that reaches a row first: height rows of width pixels of
// PaddedDisparities() uint16 lanes (the only full-size buffer of the matcher). With uint8 path
// costs each vector's worth of disparities is stored as the sums of its even disparities, then of
// its odd ones, with the matching costs in the top 6 bits when UsesPackedCosts (an internal layout
// of AggregatePaths; the final rows handed out are in order).
struct SumVolume {
  int width = 0;
  int height = 0;
  int num_disparities = 0;
  int padded = 0;
  AlignedVector<uint16_t> data;
  void Resize(int w, int h, int d);
  const uint16_t* Row(int y) const { return data.data() + static_cast<size_t>(y) * width * padded; }
  uint16_t* Row(int y) { return data.data() + static_cast<size_t>(y) * width * padded; }
};

// Path costs fit in uint8 when every one stays below 255: L <= max matching cost + P2. The
// census-only cost qualifies for P2 <= 191; the uint8 kernels process twice the disparities per
// vector.
inline bool UsesNarrowPathCosts(const AggregationInput& input) {
  return input.cost.bt_weight == 0 && MaxMatchingCost(input.cost) + input.p2 <= 254;
}

// With uint8 path costs and a census cost of at most 63, the first sweep over a row stores each
// pixel's matching costs in the top 6 bits of its partial sums (which stay below 1024) and the
// second sweep reads them instead of recomputing them.
inline bool UsesPackedCosts(const AggregationInput& input) {
  return UsesNarrowPathCosts(input) && MaxMatchingCost(input.cost) <= 63;
}

// Scratch of one sweep direction (reused between frames).
struct SweepScratch {
  AlignedVector<uint8_t> buffers;  // path costs (uint8 or uint16 lanes, see UsesNarrowPathCosts)
  AlignedVector<uint64_t> census_reversed;
  AlignedVector<uint8_t> planes_reversed;  // byte planes of census_reversed (uint8 path costs)
  AlignedVector<uint16_t> bt_reversed;
  AlignedVector<uint16_t> bt_left;
  AlignedVector<uint16_t> total_row;  // final S of the row being finished
};

// Receives the final S of row y: width pixels of PaddedDisparities() lanes; lanes k >=
// num_disparities hold 0xFFFF (saturated sums of sentinels). The pointer is valid during the call
// only.
using RowDone = std::function<void(int y, const uint16_t* sum_row)>;

// Runs the forward sweep (paths from the left / top) and the backward sweep (from the right /
// bottom). The sweep that reaches a row first streams its 4-path (or 2-path) sum into `sum`; the
// second adds its own and hands the final row to `row_done(y, S row)` (called once per row, from
// the thread that finished it). With threads >= 2 the sweeps run concurrently: each first writes
// its half of the rows, then, after a barrier, finishes the other half; integer sums make the
// result independent of the schedule.
void AggregatePaths(const AggregationInput& input, int threads, SumVolume* sum,
                    SweepScratch* forward, SweepScratch* backward, const RowDone& row_done);

// ---------------------------------------------------------------------------------------------------------
// Winner-takes-all of one row of S.
//   best[x]   = smallest k with S(x, k) minimal
//   best_cost = S(x, best), second_cost = min S(x, k) over |k - best| > 1 (0xFFFF if none)
//   right_best[xr] / right_cost[xr]: smallest k minimising S(xr + min_disparity + k, k) over the
//   left pixels x = xr + min_disparity + k inside the image (right_best = -1 if there is none).
struct WtaRow {
  int16_t* best = nullptr;          // width
  uint16_t* best_cost = nullptr;    // width
  uint16_t* second_cost = nullptr;  // width; nullptr = not needed (not computed)
  int16_t* right_best = nullptr;    // width
};
// `right_scratch` holds WtaScratchSize(width, num_disparities) uint16.
void WinnerTakesAllRow(const uint16_t* sum_row, int width, int num_disparities, int min_disparity,
                       WtaRow out, uint16_t* right_scratch);
inline size_t WtaScratchSize(int width, int num_disparities) {
  return 2 * (static_cast<size_t>(width) + PaddedDisparities(num_disparities) + 64);
}

// ---------------------------------------------------------------------------------------------------------
// Scalar stages (cheap per pixel; no SIMD).

// Subpixel offset in 1/kSgmSubpixelScale px for costs c0 = S(k-1), c1 = S(k), c2 = S(k+1), rounded
// half away from zero. kEquiangular: (c0 - c2) / (2 (max(c0, c2) - c1)); kParabola: (c0 - c2) / (2
// (c0 + c2 - 2 c1)); 0 when the denominator is 0.
int SubpixelOffset(int mode, int c0, int c1, int c2);  // mode: static_cast<int>(SgmSubpixel)

// Left-right consistency: true when the right winner at x - (min_disparity + best) exists and
// differs from `best` by at most max_diff.
bool LeftRightConsistent(int x, int best, const int16_t* right_best, int width, int min_disparity,
                         int max_diff);

// 3×3 median over valid neighbours of each valid pixel (int16 fixed point, kSgmInvalidFixed =
// invalid); the lower median when the count is even. Rows [row_begin, row_end) of dst.
void MedianValid3x3(const cv::Mat& src, cv::Mat& dst, int row_begin, int row_end);

// Speckle filter: every 4-connected piece of pixels != kSgmInvalidFixed whose neighbours differ by
// at most max_diff and that has at most max_speckle_size pixels becomes kSgmInvalidFixed — the
// result of cv::filterSpeckles(*map, kSgmInvalidFixed, max_speckle_size, max_diff), computed over
// `threads` row stripes (identical for any thread count). CV_16SC1.
void FilterSpeckles(cv::Mat* map, int max_speckle_size, int max_diff, int threads);

// Name of the Highway target the kernels dispatch to.
std::string DispatchedTargetName();

// Runs fn(begin, end) over [0, n) split into `threads` contiguous parts (fn must be independent per
// index).
void ParallelRanges(int n, int threads, const std::function<void(int, int)>& fn);

}  // namespace linesight::detail
