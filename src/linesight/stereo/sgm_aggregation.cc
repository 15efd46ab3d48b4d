// SIMD kernels of the SGM path aggregation (AggregatePaths, sgm_stages.h): the forward and
// backward sweeps with uint8 or uint16 path costs, compiled once per Highway target
// (foreach_target) and dispatched at run time.
// The kernels are defined in integers only, so every target gives bit-identical results;
// sgm_reference_test.cc checks them against their naive scalar reference (sgm_reference.h) on every
// target the CPU supports.

#include <sys/mman.h>

#include <algorithm>
#include <cstdlib>
#include <new>
#include <thread>
#include <type_traits>

#include "linesight/core/error.h"
#include "linesight/stereo/sgm_stages.h"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "linesight/stereo/sgm_aggregation.cc"
#include <hwy/cache_control.h>
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include "linesight/stereo/sgm_cost-inl.h"
#include "linesight/stereo/sgm_lanes-inl.h"

HWY_BEFORE_NAMESPACE();
namespace linesight::detail {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// Path costs are uint8 when MaxMatchingCost + P2 <= 255 (census without BT and P2 <=
// 191: twice the lanes per vector), uint16 otherwise. Either way every path cost stays below its
// sentinel and results are identical.
template <typename T>
constexpr T PathSentinel() {
  return sizeof(T) == 1 ? T{0xFF} : static_cast<T>(kSgmPathSentinel);
}

// Path buffers of one sweep: for each of the three paths that come from the previous row (vertical,
// diagonal, anti-diagonal) two rows (by parity of the sweep step) of `width` slots, plus two slots
// of the horizontal path. Slot s occupies [s * slot, (s + 1) * slot): kSgmLaneAlign guard lanes,
// then `padded` data lanes; the guard of the next slot (or the trailing guard) follows the data.
// After the slots: per-path minima (6 rows of width), the horizontal minima, the pixel's costs, and
// an all-zero slot for the first pixel of each path.
struct SweepLayout {
  int width = 0;
  int padded = 0;
  size_t slot = 0;  // lanes per slot
  size_t RowBuffer(int path, int parity) const {
    return (static_cast<size_t>(path) * 2 + parity) * width * slot;
  }
  size_t Horizontal(int parity) const {
    return 6 * static_cast<size_t>(width) * slot + parity * slot;
  }
  size_t Slots() const { return 6 * static_cast<size_t>(width) * slot + 2 * slot + kSgmLaneAlign; }
  size_t Minima(int path, int parity) const {
    return Slots() + (static_cast<size_t>(path) * 2 + parity) * width;
  }
  // Rounded up to whole vectors, so that the pixel's costs and the zero slot are vector-aligned.
  size_t HorizontalMinima() const {
    return Slots() +
           (6 * static_cast<size_t>(width) + kSgmLaneAlign - 1) / kSgmLaneAlign * kSgmLaneAlign;
  }
  size_t Cost() const { return HorizontalMinima() + kSgmLaneAlign; }
  size_t ZeroSlot() const { return Cost() + padded + kSgmLaneAlign; }
  size_t Total() const { return ZeroSlot() + padded + kSgmLaneAlign; }
};

SweepLayout MakeLayout(int width, int num_disparities) {
  SweepLayout layout;
  layout.width = width;
  layout.padded = PaddedDisparities(num_disparities);
  layout.slot = static_cast<size_t>(layout.padded) + kSgmLaneAlign;
  return layout;
}

// Previous-pixel state of one path for the current pixel. A path that starts at this pixel reads
// the all-zero slot with prev_min 0, for which the recurrence reduces to L = C.
template <typename T>
struct PathStep {
  const T* prev = nullptr;  // data lanes of the predecessor's L
  T prev_min = 0;
  T jump = 0;  // prev_min + P2', saturated to T (harmless: the minimum never exceeds the largest
               // path cost)
  T* cur = nullptr;
  T* cur_min = nullptr;
};

// Adds the uint16 lanes of the path-cost vector l (of T) into acc0. For uint8 lanes acc1 takes the
// odd disparities of the vector and acc0 the byte pairs (even + 256 odd, modulo 2^16): after the
// last path EvenSums(acc0, acc1) leaves the even disparities' sums in acc0 (shifts instead of
// cross-lane widening; EvenOddToNatural restores the order).
template <class D, class DW, class V, class VW>
HWY_INLINE void Accumulate(D d, DW dw, V l, VW* acc0, VW* acc1) {
#if HWY_TARGET != HWY_SCALAR
  if constexpr (sizeof(hn::TFromD<D>) == 1) {
    (void)d;
    const auto pairs = hn::BitCast(dw, l);
    *acc0 = hn::Add(*acc0, pairs);
    *acc1 = hn::Add(*acc1, hn::ShiftRight<8>(pairs));
  } else
#endif
  {
    (void)d;
    (void)dw;
    (void)acc1;
    *acc0 = hn::Add(*acc0, l);
  }
}

#if HWY_TARGET != HWY_SCALAR
// Sums of the even (`even`) and odd (`odd`) disparities of one uint8 vector → the same sums in
// disparity order: `lo` holds the first half of the disparities, `hi` the second.
template <class DW, class VW>
HWY_INLINE void EvenOddToNatural(DW dw, VW even, VW odd, VW* lo, VW* hi) {
#if HWY_TARGET <= HWY_AVX3
  (void)dw;
  alignas(64) static constexpr uint16_t kLow[32] = {0,  32, 1,  33, 2,  34, 3,  35, 4,  36, 5,
                                                    37, 6,  38, 7,  39, 8,  40, 9,  41, 10, 42,
                                                    11, 43, 12, 44, 13, 45, 14, 46, 15, 47};
  alignas(64) static constexpr uint16_t kHigh[32] = {16, 48, 17, 49, 18, 50, 19, 51, 20, 52, 21,
                                                     53, 22, 54, 23, 55, 24, 56, 25, 57, 26, 58,
                                                     27, 59, 28, 60, 29, 61, 30, 62, 31, 63};
  *lo = VW{_mm512_permutex2var_epi16(even.raw, _mm512_load_si512(kLow), odd.raw)};
  *hi = VW{_mm512_permutex2var_epi16(even.raw, _mm512_load_si512(kHigh), odd.raw)};
#else
  // InterleaveLower / Upper work per 128-bit block: block b of `il` holds disparities 16b..16b+7,
  // of `iu` 16b+8..16b+15.
  const VW il = hn::InterleaveLower(dw, even, odd);
  const VW iu = hn::InterleaveUpper(dw, even, odd);
  if constexpr (hn::MaxLanes(dw) * sizeof(uint16_t) == 32) {
    *lo = hn::ConcatLowerLower(dw, iu, il);
    *hi = hn::ConcatUpperUpper(dw, iu, il);
  } else {
    static_assert(hn::MaxLanes(dw) * sizeof(uint16_t) == 16, "128, 256 or 512-bit vectors");
    *lo = il;
    *hi = iu;
  }
#endif
}
#endif

// The horizontal path reads the L its previous pixel stored a few cycles earlier. Unaligned loads
// at k - 1 and k + 1 span two of those stores, which the CPU cannot forward: each waits until the
// stores have left the store buffer, on the path's critical chain. On x86 the horizontal path
// therefore loads whole vectors at the offsets they were stored at and builds the k - 1 / k + 1
// neighbours from them in registers (same lanes as the unaligned loads, so identical results).
#undef LINESIGHT_SGM_NEIGHBOUR_SHUFFLE
#if HWY_ARCH_X86 && HWY_TARGET <= HWY_SSE4
#define LINESIGHT_SGM_NEIGHBOUR_SHUFFLE 1
#else
#define LINESIGHT_SGM_NEIGHBOUR_SHUFFLE 0
#endif
#if LINESIGHT_SGM_NEIGHBOUR_SHUFFLE
// below[j] = lane j - 1 of (lower, same) (lane -1 = top lane of lower); above[j] = lane j + 1 of
// (same, upper).
template <typename T, class V>
HWY_INLINE void NeighbourLanes(V lower, V same, V upper, V* below, V* above) {
  constexpr int kBytes = sizeof(T);
#if HWY_TARGET <= HWY_AVX3
  // 128-bit blocks shifted by one across the vector, then bytes within the blocks.
  const __m512i lower_blocks = _mm512_alignr_epi64(same.raw, lower.raw, 6);
  const __m512i upper_blocks = _mm512_alignr_epi64(upper.raw, same.raw, 2);
  *below = V{_mm512_alignr_epi8(same.raw, lower_blocks, 16 - kBytes)};
  *above = V{_mm512_alignr_epi8(upper_blocks, same.raw, kBytes)};
#elif HWY_TARGET == HWY_AVX2
  const __m256i lower_blocks = _mm256_permute2x128_si256(lower.raw, same.raw, 0x21);
  const __m256i upper_blocks = _mm256_permute2x128_si256(same.raw, upper.raw, 0x21);
  *below = V{_mm256_alignr_epi8(same.raw, lower_blocks, 16 - kBytes)};
  *above = V{_mm256_alignr_epi8(upper_blocks, same.raw, kBytes)};
#else
  *below = V{_mm_alignr_epi8(same.raw, lower.raw, 16 - kBytes)};
  *above = V{_mm_alignr_epi8(upper.raw, same.raw, kBytes)};
#endif
}
#endif

// With uint8 path costs a sum of at most four of them is below 1024 (10 bits) and a census cost of
// at most 63 fits the 6 bits above it: the first sweep stores the pixel's costs there, and the
// second reads them back instead of recomputing the Hamming distances (UsesPackedCosts).
constexpr int kPackedCostShift = 10;
constexpr uint16_t kPackedSumMask = (1u << kPackedCostShift) - 1;

// One pixel: computes L of kPaths paths from the pixel's costs, stores them and their minima, and
// either streams their sum into `partial` (first sweep over this row) or adds the other sweep's
// partial sum and writes the final S into `total`.
template <typename T, int kPaths, bool kAdd, bool kPackedCost>
HWY_INLINE void AggregatePixel(const T* HWY_RESTRICT cost, const PathStep<T>* steps,
                               int full_chunks_end, int padded, size_t tail_valid_first, T p1,
                               uint16_t* HWY_RESTRICT partial, uint16_t* HWY_RESTRICT total) {
  const hn::ScalableTag<T> d;
  using V = hn::Vec<decltype(d)>;
  // Sum lanes: uint16 covering the same disparities as one vector of T.
  using DW =
      std::conditional_t<sizeof(T) == 1, hn::Rebind<uint16_t, hn::Half<decltype(d)>>, decltype(d)>;
  const DW dw;
  using VW = hn::Vec<DW>;
  const int n = static_cast<int>(hn::Lanes(d));
  const int nw = static_cast<int>(hn::Lanes(dw));
  const V p1v = hn::Set(d, p1);
  const V sentinel = hn::Set(d, PathSentinel<T>());
  const T* prev[kPaths];
  T* cur[kPaths];
  V prev_min[kPaths], jump[kPaths], minima[kPaths];
  for (int p = 0; p < kPaths; ++p) {
    prev[p] = steps[p].prev;
    cur[p] = steps[p].cur;
    prev_min[p] = hn::Set(d, steps[p].prev_min);
    jump[p] = hn::Set(d, steps[p].jump);
    minima[p] = sentinel;
  }
  auto chunk = [&](int k, bool partial_chunk, size_t valid_lanes) HWY_ATTR {
    V c;
    VW partial_even = hn::Zero(dw), partial_odd = hn::Zero(dw);  // the other sweep's sums (kAdd)
    if constexpr (kAdd) {
      partial_even = hn::Load(dw, partial + k);
      if constexpr (sizeof(T) == 1) partial_odd = hn::Load(dw, partial + k + nw);
    }
#if HWY_TARGET != HWY_SCALAR
    if constexpr (kPackedCost && kAdd) {
      // The first sweep left the costs of this chunk in the top 6 bits of its sums: even
      // disparities in partial_even, odd ones in partial_odd, i.e. byte pairs (even, odd).
      const VW mask = hn::Set(dw, uint16_t{kPackedSumMask});
      c = hn::BitCast(d, hn::Or(hn::ShiftRight<kPackedCostShift>(partial_even),
                                hn::AndNot(hn::Set(dw, uint16_t{0x00FF}),
                                           hn::ShiftRight<kPackedCostShift - 8>(partial_odd))));
      partial_even = hn::And(partial_even, mask);
      partial_odd = hn::And(partial_odd, mask);
    } else
#endif
    {
      c = hn::LoadU(d, cost + k);
    }
    VW acc0 = hn::Zero(dw), acc1 = hn::Zero(dw);
    for (int p = 0; p < kPaths; ++p) {
      const V same = hn::LoadU(d, prev[p] + k);
      V below, above;
#if LINESIGHT_SGM_NEIGHBOUR_SHUFFLE
      if (p == 0) {  // the horizontal path (see NeighbourLanes)
        NeighbourLanes<T>(hn::LoadU(d, prev[p] + k - n), same, hn::LoadU(d, prev[p] + k + n),
                          &below, &above);
      } else
#endif
      {
        below = hn::LoadU(d, prev[p] + k - 1);
        above = hn::LoadU(d, prev[p] + k + 1);
      }
      V best = hn::Min(same, hn::SaturatedAdd(hn::Min(below, above), p1v));
      best = hn::Min(best, jump[p]);
      V l = hn::Add(c, hn::Sub(best, prev_min[p]));
      if (partial_chunk) l = hn::IfThenElse(hn::FirstN(d, valid_lanes), l, sentinel);
      hn::StoreU(l, d, cur[p] + k);
      minima[p] = hn::Min(minima[p], l);
      Accumulate(d, dw, l, &acc0, &acc1);
    }
#if HWY_TARGET != HWY_SCALAR
    if constexpr (sizeof(T) == 1) {
      // Sum of pairs minus 256 x the odd sums = the even sums, exact: they stay below 2^16.
      acc0 = hn::Sub(acc0, hn::ShiftLeft<8>(acc1));
    }
#endif
    if constexpr (kAdd) {
#if HWY_TARGET != HWY_SCALAR
      if constexpr (sizeof(T) == 1) {
        // `partial` holds the even sums, then the odd sums of the chunk.
        VW lo, hi;
        EvenOddToNatural(dw, hn::Add(acc0, partial_even), hn::Add(acc1, partial_odd), &lo, &hi);
        hn::StoreU(lo, dw, total + k);
        hn::StoreU(hi, dw, total + k + nw);
      } else
#endif
      {
        hn::StoreU(hn::Add(acc0, partial_even), dw, total + k);
      }
    } else {
#if HWY_TARGET != HWY_SCALAR
      if constexpr (kPackedCost) {
        // Cost c of the even disparities (low bytes of the pairs) and of the odd ones (high
        // bytes) into the top bits of the sums: the second sweep needs no cost computation.
        const VW pairs = hn::BitCast(dw, c);
        const VW top = hn::Set(dw, uint16_t{static_cast<uint16_t>(~kPackedSumMask)});
        acc0 = hn::Or(acc0, hn::And(hn::ShiftLeft<kPackedCostShift>(pairs), top));
        acc1 = hn::Or(acc1, hn::And(hn::ShiftLeft<kPackedCostShift - 8>(pairs), top));
      }
#endif
      hn::Stream(acc0, dw, partial + k);  // read by the other sweep much later: bypass the caches
      if (sizeof(T) == 1) hn::Stream(acc1, dw, partial + k + nw);
    }
  };
  int k = 0;
  for (; k < full_chunks_end; k += n) chunk(k, false, 0);
  for (; k < padded; k += n) chunk(k, true, k == full_chunks_end ? tail_valid_first : 0);
  for (int p = 0; p < kPaths; ++p) *steps[p].cur_min = SmallestLane(d, minima[p]);
}

// Sweep steps [step_begin, step_end): step t is row t (forward) or row height-1-t (backward).
// Forward paths come from the left, top, top-left and top-right; backward paths from the right,
// bottom, bottom-right, bottom-left.
// Pixels ahead at which the second sweep prefetches the other sweep's partial sums.
constexpr int kPrefetchPixels = 4;
template <typename T, int kPaths, bool kAdd, bool kPackedCost>
void SweepSteps(const AggregationInput& in, int direction, int step_begin, int step_end,
                const uint16_t* p2_table, SumVolume* sum, T* base, SweepScratch* scratch,
                const RowDone* row_done) {
  const CostInput& cin = in.cost;
  const int w = cin.width, h = cin.height, num = cin.num_disparities;
  const SweepLayout layout = MakeLayout(w, num);
  const int padded = layout.padded;
  const int n = static_cast<int>(hn::Lanes(hn::ScalableTag<T>()));
  const int full_chunks_end = num / n * n;
  const size_t tail_valid_first = static_cast<size_t>(num - full_chunks_end);
  T* minima = base + layout.Minima(0, 0);
  T* horizontal_min = base + layout.HorizontalMinima();
  T* cost = base + layout.Cost();
  const T* zero_slot = base + layout.ZeroSlot();
  const int guard = kSgmLaneAlign;
  const T p1 = static_cast<T>(in.p1);
  constexpr int kMaxT = sizeof(T) == 1 ? 0xFF : 0xFFFF;
  auto jump = [&](T prev_min, int step) {
    return static_cast<T>(std::min(kMaxT, prev_min + p2_table[step]));
  };
  CostRowContext ctx;
  for (int t = step_begin; t < step_end; ++t) {
    const int y = direction > 0 ? t : h - 1 - t;
    const int prev_y = y - direction;
    const int cur_parity = t & 1, prev_parity = 1 - cur_parity;
    // The second sweep over a row reads packed costs: no census row to prepare.
    if (!(kAdd && kPackedCost)) {
      PrepareCostRow(cin, y, padded, &scratch->census_reversed, &scratch->bt_reversed,
                     &scratch->bt_left, sizeof(T) == 1 ? &scratch->planes_reversed : nullptr, &ctx);
    }
    const uint8_t* gray = cin.gray_left + static_cast<size_t>(y) * w;
    const uint8_t* gray_prev = t > 0 ? cin.gray_left + static_cast<size_t>(prev_y) * w : nullptr;
    uint16_t* partial_row = sum->Row(y);
    uint16_t* total_row = scratch->total_row.data();
    for (int i = 0; i < w; ++i) {
      const int x = direction > 0 ? i : w - 1 - i;
      if (kAdd && i + kPrefetchPixels < w) {
        const uint16_t* ahead =
            partial_row + static_cast<size_t>(x + kPrefetchPixels * direction) * padded;
        for (int line = 0; line < padded; line += 32) hwy::Prefetch(ahead + line);
      }
      if (!(kAdd && kPackedCost)) PixelCost<T>(ctx, x, cost);
      PathStep<T> steps[kPaths];
      // Horizontal path from x - direction.
      {
        PathStep<T>& s = steps[0];
        const int hp = i & 1;
        s.cur = base + layout.Horizontal(hp) + guard;
        s.cur_min = &horizontal_min[hp];
        if (i > 0) {
          s.prev = base + layout.Horizontal(1 - hp) + guard;
          s.prev_min = horizontal_min[1 - hp];
          s.jump = jump(s.prev_min, std::abs(gray[x] - gray[x - direction]));
        } else {
          s.prev = zero_slot;
        }
      }
      // Paths from the previous row: vertical (dx = 0), diagonal (dx = -direction), anti-diagonal
      // (+direction).
      for (int p = 0; p + 1 < kPaths; ++p) {
        const int dx = p == 0 ? 0 : (p == 1 ? -direction : direction);
        PathStep<T>& s = steps[p + 1];
        s.cur =
            base + layout.RowBuffer(p, cur_parity) + static_cast<size_t>(x) * layout.slot + guard;
        s.cur_min = base + layout.Minima(p, cur_parity) + x;
        const int px = x + dx;
        if (t > 0 && px >= 0 && px < w) {
          s.prev = base + layout.RowBuffer(p, prev_parity) + static_cast<size_t>(px) * layout.slot +
                   guard;
          s.prev_min = base[layout.Minima(p, prev_parity) + px];
          s.jump = jump(s.prev_min, std::abs(gray[x] - gray_prev[px]));
        } else {
          s.prev = zero_slot;
        }
      }
      (void)minima;
      uint16_t* total = total_row + static_cast<size_t>(x) * padded;
      AggregatePixel<T, kPaths, kAdd, kPackedCost>(
          cost, steps, full_chunks_end, padded, tail_valid_first, p1,
          partial_row + static_cast<size_t>(x) * padded, total);
      // Padding lanes of the final S hold 0xFFFF so that no winner-takes-all can pick them.
      if (kAdd && num != padded) std::fill(total + num, total + padded, uint16_t{0xFFFF});
    }
    if (kAdd && row_done != nullptr && *row_done) (*row_done)(y, total_row);
  }
  if (!kAdd) hwy::FlushStream();
}

template <typename T>
void SweepTyped(const AggregationInput& in, int direction, int step_begin, int step_end, bool add,
                const uint16_t* p2_table, SumVolume* sum, SweepScratch* scratch,
                const RowDone* row_done) {
  const SweepLayout layout = MakeLayout(in.cost.width, in.cost.num_disparities);
  const size_t bytes = layout.Total() * sizeof(T);
  if (step_begin == 0 || scratch->buffers.size() != bytes) {
    scratch->buffers.resize(bytes);
    T* base = reinterpret_cast<T*>(scratch->buffers.data());
    std::fill(base, base + layout.Total(), PathSentinel<T>());
    std::fill(base + layout.ZeroSlot(), base + layout.ZeroSlot() + layout.padded, T{0});
  }
  T* base = reinterpret_cast<T*>(scratch->buffers.data());
  const bool eight = in.num_paths == 8;
  const auto run = [&](auto paths, auto add_tag, auto packed) {
    SweepSteps<T, decltype(paths)::value, decltype(add_tag)::value, decltype(packed)::value>(
        in, direction, step_begin, step_end, p2_table, sum, base, scratch, row_done);
  };
  const auto with_packing = [&](auto paths, auto add_tag) {
    if constexpr (sizeof(T) == 1) {
      if (UsesPackedCosts(in)) return run(paths, add_tag, std::true_type());
    }
    run(paths, add_tag, std::false_type());
  };
  const auto with_add = [&](auto paths) {
    if (add) {
      with_packing(paths, std::true_type());
    } else {
      with_packing(paths, std::false_type());
    }
  };
  if (eight) {
    with_add(std::integral_constant<int, 4>());
  } else {
    with_add(std::integral_constant<int, 2>());
  }
}

void SweepImpl(const AggregationInput& in, int direction, int step_begin, int step_end, bool add,
               const uint16_t* p2_table, SumVolume* sum, SweepScratch* scratch,
               const RowDone* row_done) {
  scratch->total_row.resize(static_cast<size_t>(in.cost.width) *
                            PaddedDisparities(in.cost.num_disparities));
#if HWY_TARGET != HWY_SCALAR  // one lane per vector: nothing to gain from uint8 lanes
  if (UsesNarrowPathCosts(in)) {
    SweepTyped<uint8_t>(in, direction, step_begin, step_end, add, p2_table, sum, scratch, row_done);
    return;
  }
#endif
  SweepTyped<uint16_t>(in, direction, step_begin, step_end, add, p2_table, sum, scratch, row_done);
}

}  // namespace HWY_NAMESPACE
}  // namespace linesight::detail
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace linesight::detail {

namespace {
constexpr size_t kHugePage = size_t{2} << 20;
constexpr size_t kHugeFrom = size_t{4} << 20;
}  // namespace

void* AllocateVolume(size_t bytes) {
  if (bytes < kHugeFrom) return ::operator new (bytes, std::align_val_t{64});
  const size_t rounded = (bytes + kHugePage - 1) / kHugePage * kHugePage;
  void* p = ::operator new (rounded, std::align_val_t{kHugePage});
  madvise(p, rounded, MADV_HUGEPAGE);  // advice only: without THP the pages stay 4 KiB
  return p;
}

void FreeVolume(void* p, size_t bytes) {
  ::operator delete (p, std::align_val_t{bytes < kHugeFrom ? size_t{64} : kHugePage});
}

HWY_EXPORT(SweepImpl);

void SumVolume::Resize(int w, int h, int d) {
  width = w;
  height = h;
  num_disparities = d;
  padded = PaddedDisparities(d);
  const size_t lanes = static_cast<size_t>(w) * h * padded;
  if (data.size() != lanes) {
    data = AlignedVector<uint16_t>();
    data.resize(lanes);
  }
}

void AggregatePaths(const AggregationInput& input, int threads, SumVolume* sum,
                    SweepScratch* forward, SweepScratch* backward, const RowDone& row_done) {
  LS_CHECK(input.num_paths == 4 || input.num_paths == 8);
  LS_CHECK(MaxMatchingCost(input.cost) + input.p2 <= kSgmMaxPathCost);
  const int h = input.cost.height;
  sum->Resize(input.cost.width, h, input.cost.num_disparities);
  uint16_t p2_table[256];
  for (int g = 0; g < 256; ++g) {
    int p2 = input.p2;
    if (input.p2_gradient_alpha > 0) {
      p2 = std::max(input.p1 + 1,
                    input.p2 * input.p2_gradient_alpha / (input.p2_gradient_alpha + g));
    }
    p2_table[g] = static_cast<uint16_t>(p2);
  }
  const auto sweep = HWY_DYNAMIC_DISPATCH(SweepImpl);
  const RowDone* done = row_done ? &row_done : nullptr;
  if (threads <= 1 || h < 2) {
    sweep(input, +1, 0, h, false, p2_table, sum, forward, nullptr);
    sweep(input, -1, 0, h, true, p2_table, sum, backward, done);
    return;
  }
  // Phase 1: each sweep writes its first half of the rows; phase 2: each adds into the other half,
  // which the opposite sweep has finished, so every row is final as soon as the second sweep leaves
  // it.
  const int mid = h / 2;
  {
    std::thread worker(
        [&] { sweep(input, -1, 0, h - mid, false, p2_table, sum, backward, nullptr); });
    sweep(input, +1, 0, mid, false, p2_table, sum, forward, nullptr);
    worker.join();
  }
  {
    std::thread worker([&] { sweep(input, -1, h - mid, h, true, p2_table, sum, backward, done); });
    sweep(input, +1, mid, h, true, p2_table, sum, forward, done);
    worker.join();
  }
}

}  // namespace linesight::detail
#endif  // HWY_ONCE
