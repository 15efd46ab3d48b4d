// SIMD kernel of the SGM winner-takes-all over one row of path sums, left and right view
// (WinnerTakesAllRow, sgm_stages.h), compiled once per Highway target (foreach_target) and
// dispatched at run time.
// The kernel is defined in integers only, so every target gives bit-identical results;
// sgm_reference_test.cc checks it against its naive scalar reference (sgm_reference.h) on every
// target the CPU supports.

#include <algorithm>
#include <cstdint>

#include "linesight/stereo/sgm_stages.h"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "linesight/stereo/sgm_winner_takes_all.cc"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include "linesight/stereo/sgm_lanes-inl.h"

HWY_BEFORE_NAMESPACE();
namespace linesight::detail {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// Left view: per pixel, the smallest lane (folded reduction), the first lane equal to it, and the
// smallest lane outside the ±1 neighbourhood of the winner.
//
// Right view: right pixel xr collects S(xr + min_disparity + k, k) along a diagonal of the row. A
// "shift register" of padded + one vector of uint16 lanes holds, after pixel x, the running minimum
// (and its k) of right pixel xr = x - min_disparity - j in lane j: before each pixel every lane
// moves up by one, then lanes k < padded take S(x, k) when it is strictly smaller (the smallest k
// wins ties because lanes are visited in increasing k for a fixed xr). Lanes >= padded only carry
// finished values; every vector's worth of pixels the top vector is written out.

// Lanes of `cur` moved up by one; lane 0 takes the top lane of `below` (the next lower vector).
// (re-evaluated for every target that foreach_target compiles)
#undef LINESIGHT_SGM_SHIFT_REGISTER
#if HWY_ARCH_X86 && HWY_TARGET <= HWY_SSE4
#define LINESIGHT_SGM_SHIFT_REGISTER 1
#else
#define LINESIGHT_SGM_SHIFT_REGISTER 0
#endif
#if LINESIGHT_SGM_SHIFT_REGISTER
template <class D, class V>
HWY_INLINE V ShiftUpOneLane(D /*d*/, V cur, V below) {
#if HWY_TARGET <= HWY_AVX3
  const __m512i carried = _mm512_alignr_epi64(cur.raw, below.raw, 7);
#if HWY_TARGET <= HWY_AVX3_DL
  return V{_mm512_shldi_epi64(cur.raw, carried, 16)};
#else
  return V{_mm512_or_si512(_mm512_slli_epi64(cur.raw, 16), _mm512_srli_epi64(carried, 48))};
#endif
#elif HWY_TARGET == HWY_AVX2
  return V{_mm256_alignr_epi8(cur.raw, _mm256_permute2x128_si256(below.raw, cur.raw, 0x21), 14)};
#else
  return V{_mm_alignr_epi8(cur.raw, below.raw, 14)};
#endif
}
#endif

#if LINESIGHT_SGM_SHIFT_REGISTER
// The same with kVectors = padded / Lanes vectors per pixel known at compile time: the pixel's
// costs and the shift register stay in registers, and the winner's index is found without branches
// (the smallest index among the lanes equal to the minimum).
template <int kVectors, bool kSecond>
void WinnerTakesAllRowRegisters(const uint16_t* sum_row, int width, int min_disparity, WtaRow out) {
  const hn::ScalableTag<uint16_t> d;
  using V = hn::Vec<decltype(d)>;
  constexpr int kMaxLanes = static_cast<int>(hn::MaxLanes(d));
  const int n = static_cast<int>(hn::Lanes(d));
  const int padded = kVectors * n;
  const V all_ones = hn::Set(d, uint16_t{0xFFFF});
  V iota[kVectors], run_cost[kVectors + 1], run_k[kVectors + 1];
  for (int v = 0; v < kVectors; ++v) iota[v] = hn::Iota(d, static_cast<uint16_t>(v * n));
  for (int v = 0; v <= kVectors; ++v) run_cost[v] = run_k[v] = all_ones;
  alignas(64) uint16_t lanes[(kVectors + 1) * kMaxLanes];
  // Sliding window of the lanes excluded from the second best: excluded[padded + k - best] is
  // 0xFFFF for k = best - 1, best, best + 1 and 0 otherwise, so OR-ing a vector of costs with the
  // window at its offset removes those lanes from the minimum.
  alignas(64) uint16_t excluded[3 * kVectors * kMaxLanes] = {};
  for (int i = padded - 1; i <= padded + 1; ++i) excluded[i] = 0xFFFF;
  // Lane j of the register holds right pixel x_last - min_disparity - j.
  auto emit = [&](int first_vector, int x_last) HWY_ATTR {
    for (int v = first_vector; v <= kVectors; ++v) hn::Store(run_k[v], d, lanes + v * n);
    for (int j = first_vector * n; j < (kVectors + 1) * n; ++j) {
      const int xr = x_last - min_disparity - j;
      if (xr >= 0 && xr < width) out.right_best[xr] = static_cast<int16_t>(lanes[j]);
    }
  };
  for (int x = 0; x < width; ++x) {
    const uint16_t* s = sum_row + static_cast<size_t>(x) * padded;
    V costs[kVectors];
    for (int v = 0; v < kVectors; ++v) costs[v] = hn::LoadU(d, s + v * n);
    V mn = costs[0];
    for (int v = 1; v < kVectors; ++v) mn = hn::Min(mn, costs[v]);
    const uint16_t best_cost = SmallestLane(d, mn);
    const V best_cost_v = hn::Set(d, best_cost);
    V index = all_ones;
    for (int v = 0; v < kVectors; ++v) {
      index = hn::Min(index, hn::IfThenElse(hn::Eq(costs[v], best_cost_v), iota[v], all_ones));
    }
    const int best = SmallestLane(d, index);
    out.best[x] = static_cast<int16_t>(best);
    out.best_cost[x] = best_cost;
    if constexpr (kSecond) {
      // Second best more than one disparity away.
      const uint16_t* window = excluded + padded - best;
      V second = all_ones;
      for (int v = 0; v < kVectors; ++v) {
        second = hn::Min(second, hn::Or(costs[v], hn::LoadU(d, window + v * n)));
      }
      out.second_cost[x] = SmallestLane(d, second);
    }
    // Right view: every lane moves up by one, then lanes k < padded take S(x, k) when smaller.
    run_cost[kVectors] = ShiftUpOneLane(d, run_cost[kVectors], run_cost[kVectors - 1]);
    run_k[kVectors] = ShiftUpOneLane(d, run_k[kVectors], run_k[kVectors - 1]);
    for (int v = kVectors - 1; v >= 0; --v) {
      const V cost = ShiftUpOneLane(d, run_cost[v], v > 0 ? run_cost[v - 1] : all_ones);
      const V k = ShiftUpOneLane(d, run_k[v], v > 0 ? run_k[v - 1] : all_ones);
      run_k[v] = hn::IfThenElse(hn::Lt(costs[v], cost), iota[v], k);
      run_cost[v] = hn::Min(costs[v], cost);
    }
    if ((x + 1) % n == 0) emit(kVectors, x);
  }
  emit(0, width - 1);
}
#endif

void WinnerTakesAllRowImpl(const uint16_t* sum_row, int width, int num_disparities,
                           int min_disparity, WtaRow out, uint16_t* right_cost_scratch) {
  const hn::ScalableTag<uint16_t> d;
  const int n = static_cast<int>(hn::Lanes(d));
  const int padded = PaddedDisparities(num_disparities);
  const auto all_ones = hn::Set(d, uint16_t{0xFFFF});
  const auto two = hn::Set(d, uint16_t{2});
  std::fill(out.right_best, out.right_best + width, int16_t{-1});
#if LINESIGHT_SGM_SHIFT_REGISTER
  switch (padded / n) {
#define LINESIGHT_SGM_WTA_CASE(count)                                               \
  case count:                                                                       \
    if (out.second_cost != nullptr) {                                               \
      WinnerTakesAllRowRegisters<count, true>(sum_row, width, min_disparity, out);  \
    } else {                                                                        \
      WinnerTakesAllRowRegisters<count, false>(sum_row, width, min_disparity, out); \
    }                                                                               \
    return;
    LINESIGHT_SGM_WTA_CASE(2)
    LINESIGHT_SGM_WTA_CASE(4)
    LINESIGHT_SGM_WTA_CASE(6)
    LINESIGHT_SGM_WTA_CASE(8)
#undef LINESIGHT_SGM_WTA_CASE
    default:
      break;
  }
#endif
#if LINESIGHT_SGM_SHIFT_REGISTER
  // Running right minima and their k: padded / n + 1 vectors each (aligned, in the scratch).
  const int vectors = padded / n;
  uint16_t* run_cost = right_cost_scratch;
  uint16_t* run_k = right_cost_scratch + padded + n;
  std::fill(run_cost, run_cost + 2 * (padded + n), uint16_t{0xFFFF});
  auto emit = [&](int first_lane, int count, int x_last) HWY_ATTR {
    // Lane j holds right pixel x_last - min_disparity - j.
    for (int j = first_lane; j < first_lane + count; ++j) {
      const int xr = x_last - min_disparity - j;
      if (xr >= 0 && xr < width) out.right_best[xr] = static_cast<int16_t>(run_k[j]);
    }
  };
#else
  const size_t reversed = static_cast<size_t>(width) + padded + 64;
  uint16_t* right_cost = right_cost_scratch;
  uint16_t* right_best = right_cost_scratch + reversed;
  std::fill(right_cost, right_cost + reversed, uint16_t{0xFFFF});
  std::fill(right_best, right_best + reversed, uint16_t{0xFFFF});
#endif
  for (int x = 0; x < width; ++x) {
    const uint16_t* s = sum_row + static_cast<size_t>(x) * padded;
    auto mn = hn::LoadU(d, s);
    for (int k = n; k < padded; k += n) mn = hn::Min(mn, hn::LoadU(d, s + k));
    const uint16_t best_cost = SmallestLane(d, mn);
    const auto best_cost_v = hn::Set(d, best_cost);
    // Branch-free: which vector holds the winner is unpredictable.
    int best = padded;
    for (int k = 0; k < padded; k += n) {
      const intptr_t idx = hn::FindFirstTrue(d, hn::Eq(hn::LoadU(d, s + k), best_cost_v));
      const int candidate = idx >= 0 ? k + static_cast<int>(idx) : padded;
      best = std::min(best, candidate);
    }
    out.best[x] = static_cast<int16_t>(best);
    out.best_cost[x] = best_cost;
    if (out.second_cost != nullptr) {
      // Second best more than one disparity away: lanes with (k - (best - 1)) mod 2^16 <= 2 are
      // excluded.
      const auto low = hn::Set(d, static_cast<uint16_t>(best - 1));
      auto second = all_ones;
      for (int k = 0; k < padded; k += n) {
        const auto v = hn::LoadU(d, s + k);
        const auto offset = hn::Sub(hn::Iota(d, static_cast<uint16_t>(k)), low);
        second = hn::IfThenElse(hn::Eq(hn::Min(offset, two), offset), second, hn::Min(second, v));
      }
      out.second_cost[x] = SmallestLane(d, second);
    }
#if LINESIGHT_SGM_SHIFT_REGISTER
    // The top vector only shifts; the others shift and take S(x, k) where it is smaller.
    hn::StoreU(
        ShiftUpOneLane(d, hn::LoadU(d, run_cost + padded), hn::LoadU(d, run_cost + padded - n)), d,
        run_cost + padded);
    hn::StoreU(ShiftUpOneLane(d, hn::LoadU(d, run_k + padded), hn::LoadU(d, run_k + padded - n)), d,
               run_k + padded);
    for (int v = vectors - 1; v >= 0; --v) {
      const int k = v * n;
      const auto below_cost = v > 0 ? hn::LoadU(d, run_cost + k - n) : all_ones;
      const auto below_k = v > 0 ? hn::LoadU(d, run_k + k - n) : all_ones;
      const auto cost = ShiftUpOneLane(d, hn::LoadU(d, run_cost + k), below_cost);
      const auto kk = ShiftUpOneLane(d, hn::LoadU(d, run_k + k), below_k);
      const auto candidate = hn::LoadU(d, s + k);
      hn::StoreU(hn::Min(candidate, cost), d, run_cost + k);
      hn::StoreU(hn::IfThenElse(hn::Lt(candidate, cost), hn::Iota(d, static_cast<uint16_t>(k)), kk),
                 d, run_k + k);
    }
    if ((x + 1) % n == 0) emit(padded, n, x);
#else
    // Right view: index i = width - 1 - x + k holds right pixel width - 1 - min_disparity - i.
    uint16_t* rc = right_cost + (width - 1 - x);
    uint16_t* rb = right_best + (width - 1 - x);
    for (int k = 0; k < padded; k += n) {
      const auto v = hn::LoadU(d, s + k);
      const auto old = hn::LoadU(d, rc + k);
      const auto better = hn::Lt(v, old);
      hn::StoreU(hn::Min(v, old), d, rc + k);
      hn::StoreU(
          hn::IfThenElse(better, hn::Iota(d, static_cast<uint16_t>(k)), hn::LoadU(d, rb + k)), d,
          rb + k);
    }
#endif
  }
#if LINESIGHT_SGM_SHIFT_REGISTER
  emit(0, padded + n, width - 1);
#else
  for (int xr = 0; xr < width; ++xr) {
    const long i = static_cast<long>(width) - 1 - min_disparity - xr;
    int16_t value = -1;
    if (i >= 0 && i < static_cast<long>(reversed) && right_cost[i] != 0xFFFF) {
      value = static_cast<int16_t>(right_best[i]);
    }
    out.right_best[xr] = value;
  }
#endif
}

}  // namespace HWY_NAMESPACE
}  // namespace linesight::detail
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace linesight::detail {

HWY_EXPORT(WinnerTakesAllRowImpl);

void WinnerTakesAllRow(const uint16_t* sum_row, int width, int num_disparities, int min_disparity,
                       WtaRow out, uint16_t* right_cost_scratch) {
  HWY_DYNAMIC_DISPATCH(WinnerTakesAllRowImpl)
  (sum_row, width, num_disparities, min_disparity, out, right_cost_scratch);
}

}  // namespace linesight::detail
#endif  // HWY_ONCE
