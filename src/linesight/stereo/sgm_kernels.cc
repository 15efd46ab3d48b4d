// SIMD kernels of the SGM pipeline, compiled once per Highway target (foreach_target) and
// dispatched at run time. Every kernel is defined in integers only, so all targets produce
// bit-identical results; sgm_reference_test.cc checks each against a naive scalar reference for
// every target the CPU supports.

#include <algorithm>
#include <bit>
#include <cstring>
#include <thread>

#include "linesight/core/error.h"
#include "linesight/stereo/sgm_stages.h"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "linesight/stereo/sgm_kernels.cc"
#include <hwy/cache_control.h>
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace linesight::detail {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

const char* TargetNameImpl() { return hwy::TargetName(HWY_TARGET); }

// ------------------------------------------------------------------------------------------------
// census `padded`: rows [row_begin - ry, row_end + ry) of the image with rx replicated columns on
// each side and at least one vector of slack after them; row r of the image is padded row r -
// (row_begin - ry).
void CensusRowsImpl(const uint8_t* padded, size_t stride, int width, const int* offset_dy,
                    const int* offset_dx, int num_bits, int rx, int ry, int row_begin, int row_end,
                    uint8_t* planes /* 8 x stride */, uint64_t* codes) {
  const hn::ScalableTag<uint8_t> d8;
  const size_t n8 = hn::Lanes(d8);
  const auto zero = hn::Zero(d8);
  const int num_groups = (num_bits + 7) / 8;
  for (int y = row_begin; y < row_end; ++y) {
    const uint8_t* centre_row = padded + static_cast<size_t>(y - row_begin + ry) * stride + rx;
    for (int x0 = 0; x0 < width; x0 += static_cast<int>(n8)) {
      const auto centre = hn::LoadU(d8, centre_row + x0);
      for (int g = 0; g < num_groups; ++g) {
        auto acc = zero;
        for (int bit = 0; bit < 8 && g * 8 + bit < num_bits; ++bit) {
          const int b = g * 8 + bit;
          const auto neighbour = hn::LoadU(
              d8, centre_row +
                      static_cast<ptrdiff_t>(offset_dy[b]) * static_cast<ptrdiff_t>(stride) + x0 +
                      offset_dx[b]);
          acc = hn::Or(acc, hn::IfThenElseZero(hn::Lt(neighbour, centre),
                                               hn::Set(d8, static_cast<uint8_t>(1u << bit))));
        }
        hn::StoreU(acc, d8, planes + static_cast<size_t>(g) * stride + x0);
      }
    }
    uint64_t* out = codes + static_cast<size_t>(y) * width;
    // Gather the byte planes into 64-bit codes a vector of pixels at a time (the planes have at
    // least one vector of slack after the row), the last partial vector in scalar code.
    const hn::ScalableTag<uint64_t> d64;
    const hn::Rebind<uint8_t, decltype(d64)> d8q;
    const int n64 = static_cast<int>(hn::Lanes(d64));
    int x = 0;
    for (; x + n64 <= width; x += n64) {
      auto code = hn::Zero(d64);
      for (int g = 0; g < num_groups; ++g) {
        const auto packed = hn::LoadU(d8q, planes + static_cast<size_t>(g) * stride + x);
        // (Highway 1.0.3 promotes uint8 to at most twice or four times the width at once)
        const hn::Rebind<uint16_t, decltype(d64)> d16q;
        const hn::Rebind<uint32_t, decltype(d64)> d32q;
        const auto bytes = hn::PromoteTo(d64, hn::PromoteTo(d32q, hn::PromoteTo(d16q, packed)));
        code = hn::Or(code, hn::ShiftLeftSame(bytes, 8 * g));
      }
      hn::StoreU(code, d64, out + x);
    }
    for (; x < width; ++x) {
      uint64_t code = 0;
      for (int g = 0; g < num_groups; ++g) {
        code |= static_cast<uint64_t>(planes[static_cast<size_t>(g) * stride + x]) << (8 * g);
      }
      out[x] = code;
    }
  }
}

// ------------------------------------------------------------------------------------------
// matching cost Per-row context of the matching cost: the right census and BT values stored in
// reverse, so that for a left pixel x the right pixels x - min_disparity - k for k = 0, 1, ... are
// contiguous from index width-1-x.
struct CostRowContext {
  const CostInput* input = nullptr;
  int padded = 0;
  int max_cost = 0;
  const uint64_t* census_left = nullptr;  // row y
  const uint64_t* census_reversed = nullptr;
  const uint16_t* bt_left = nullptr;      // 3 * width: 2I, min2, max2
  const uint16_t* bt_reversed = nullptr;  // 3 * reversed_size
  // Byte planes of the reversed right census: plane g (g < census_groups) holds byte g of each
  // code, reversed_size bytes per plane (only for uint8 path costs, see PixelCost).
  const uint8_t* planes_reversed = nullptr;
  int census_groups = 0;
  size_t reversed_size = 0;
};

// Index i of the reversed arrays holds right pixel xr = width - 1 - min_disparity - i.
// Rounded up to whole 64-lane vectors.
inline size_t ReversedSize(const CostInput& in, int padded) {
  return (static_cast<size_t>(in.width) + padded + 64 + 63) / 64 * 64;
}

void PrepareCostRow(const CostInput& in, int y, int padded,
                    AlignedVector<uint64_t>* census_reversed, AlignedVector<uint16_t>* bt_reversed,
                    AlignedVector<uint16_t>* bt_left, AlignedVector<uint8_t>* planes_reversed,
                    CostRowContext* ctx) {
  const int w = in.width;
  const size_t n = ReversedSize(in, padded);
  census_reversed->assign(n, 0);
  const uint64_t* census_right = in.census_right + static_cast<size_t>(y) * w;
  // Index i holds right pixel w - 1 - min_disparity - i, which is inside the image for i in
  // [-min_disparity, w - min_disparity).
  const long first = std::max(0L, -static_cast<long>(in.min_disparity));
  const long last = std::min(static_cast<long>(n), static_cast<long>(w) - in.min_disparity);
  if (first < last) {
    std::reverse_copy(census_right + (w - in.min_disparity - last),
                      census_right + (w - in.min_disparity - first),
                      census_reversed->data() + first);
  }
  ctx->input = &in;
  ctx->padded = padded;
  ctx->max_cost = MaxMatchingCost(in);
  ctx->census_left = in.census_left + static_cast<size_t>(y) * w;
  ctx->census_reversed = census_reversed->data();
  ctx->reversed_size = n;
  if (planes_reversed != nullptr) {
    // Transpose the codes into byte planes, one vector of codes at a time.
    const int groups = (in.census_bits + 7) / 8;
    planes_reversed->resize(static_cast<size_t>(groups) * n);
    const hn::ScalableTag<uint64_t> d64;
    const hn::Rebind<uint8_t, decltype(d64)> d8q;
    const size_t n64 = hn::Lanes(d64);
    uint8_t* planes = planes_reversed->data();
    for (size_t i = 0; i < n; i += n64) {
      const auto codes = hn::Load(d64, census_reversed->data() + i);
      for (int g = 0; g < groups; ++g) {
        hn::StoreU(hn::TruncateTo(d8q, hn::ShiftRightSame(codes, 8 * g)), d8q,
                   planes + static_cast<size_t>(g) * n + i);
      }
    }
    ctx->planes_reversed = planes;
    ctx->census_groups = groups;
  }
  if (in.bt_weight > 0) {
    // Birchfield–Tomasi in half grey levels: 2I and the min / max of 2I and the two half-pixel
    // interpolations.
    auto fill = [w](const uint8_t* row, int x, uint16_t* i2, uint16_t* mn, uint16_t* mx) {
      const int c = row[x];
      const int minus = c + row[std::max(x - 1, 0)];
      const int plus = c + row[std::min(x + 1, w - 1)];
      *i2 = static_cast<uint16_t>(2 * c);
      *mn = static_cast<uint16_t>(std::min({2 * c, minus, plus}));
      *mx = static_cast<uint16_t>(std::max({2 * c, minus, plus}));
    };
    bt_left->resize(3 * static_cast<size_t>(w));
    const uint8_t* left_row = in.gray_left + static_cast<size_t>(y) * w;
    for (int x = 0; x < w; ++x) {
      fill(left_row, x, &(*bt_left)[x], &(*bt_left)[w + x], &(*bt_left)[2 * w + x]);
    }
    bt_reversed->assign(3 * n, 0);
    const uint8_t* right_row = in.gray_right + static_cast<size_t>(y) * w;
    for (size_t i = 0; i < n; ++i) {
      const long xr = static_cast<long>(w) - 1 - in.min_disparity - static_cast<long>(i);
      if (xr >= 0 && xr < w) {
        fill(right_row, static_cast<int>(xr), &(*bt_reversed)[i], &(*bt_reversed)[n + i],
             &(*bt_reversed)[2 * n + i]);
      }
    }
    ctx->bt_left = bt_left->data();
    ctx->bt_reversed = bt_reversed->data();
  }
}

// Costs of pixel x for k in [0, padded) into out.
// T = uint8_t is only used without the BT term (MaxMatchingCost <= 64).
template <typename T>
HWY_INLINE void PixelCost(const CostRowContext& ctx, int x, T* HWY_RESTRICT out) {
  const CostInput& in = *ctx.input;
  const int padded = ctx.padded;
  const size_t base = static_cast<size_t>(in.width - 1 - x);
  if constexpr (sizeof(T) == 1) {
    // Hamming distance as the sum of byte popcounts over the byte planes: uint8 lanes throughout.
    const hn::ScalableTag<uint8_t> d8;
    const size_t n8 = hn::Lanes(d8);
    static_assert(std::endian::native == std::endian::little, "byte g of a code is at offset g");
    const uint8_t* left_bytes = reinterpret_cast<const uint8_t*>(ctx.census_left + x);
    const size_t n = ctx.reversed_size;
    const uint8_t* planes = ctx.planes_reversed + base;
    if (ctx.census_groups == 8) {
      // The default 9×7 window (62 bits): unrolled, the broadcast bytes kept in registers.
      hn::Vec<decltype(d8)> left[8];
      for (int g = 0; g < 8; ++g) left[g] = hn::Set(d8, left_bytes[g]);
      for (int k = 0; k < padded; k += static_cast<int>(n8)) {
        hn::Vec<decltype(d8)> counts[8];
        for (int g = 0; g < 8; ++g) {
          counts[g] = hn::PopulationCount(
              hn::Xor(hn::LoadU(d8, planes + static_cast<size_t>(g) * n + k), left[g]));
        }
        const auto sum =
            hn::Add(hn::Add(hn::Add(counts[0], counts[1]), hn::Add(counts[2], counts[3])),
                    hn::Add(hn::Add(counts[4], counts[5]), hn::Add(counts[6], counts[7])));
        hn::StoreU(sum, d8, out + k);
      }
    } else {
      for (int k = 0; k < padded; k += static_cast<int>(n8)) {
        auto acc = hn::Zero(d8);
        for (int g = 0; g < ctx.census_groups; ++g) {
          const auto right = hn::LoadU(d8, planes + static_cast<size_t>(g) * n + k);
          acc = hn::Add(acc, hn::PopulationCount(hn::Xor(right, hn::Set(d8, left_bytes[g]))));
        }
        hn::StoreU(acc, d8, out + k);
      }
    }
  } else {
    const hn::ScalableTag<uint64_t> d64;
    const hn::Rebind<T, decltype(d64)> d16h;
    const size_t n64 = hn::Lanes(d64);
    const auto left = hn::Set(d64, ctx.census_left[x]);
    for (int k = 0; k < padded; k += static_cast<int>(n64)) {
      const auto right = hn::LoadU(d64, ctx.census_reversed + base + k);
      const auto hamming = hn::PopulationCount(hn::Xor(left, right));
      hn::StoreU(hn::TruncateTo(d16h, hamming), d16h, out + k);
    }
  }
  if constexpr (sizeof(T) == 2) {
    if (in.bt_weight > 0) {
      const hn::ScalableTag<uint16_t> d16;
      const size_t n16 = hn::Lanes(d16);
      const size_t n = ctx.reversed_size;
      const auto il = hn::Set(d16, ctx.bt_left[x]);
      const auto il_min = hn::Set(d16, ctx.bt_left[in.width + x]);
      const auto il_max = hn::Set(d16, ctx.bt_left[2 * in.width + x]);
      const auto truncation = hn::Set(d16, static_cast<uint16_t>(2 * in.bt_truncation));
      const auto weight = hn::Set(d16, static_cast<uint16_t>(in.bt_weight));
      for (int k = 0; k < padded; k += static_cast<int>(n16)) {
        const auto ir = hn::LoadU(d16, ctx.bt_reversed + base + k);
        const auto ir_min = hn::LoadU(d16, ctx.bt_reversed + n + base + k);
        const auto ir_max = hn::LoadU(d16, ctx.bt_reversed + 2 * n + base + k);
        const auto left_to_right =
            hn::Max(hn::SaturatedSub(il, ir_max), hn::SaturatedSub(ir_min, il));
        const auto right_to_left =
            hn::Max(hn::SaturatedSub(ir, il_max), hn::SaturatedSub(il_min, ir));
        const auto bt = hn::Min(hn::Min(left_to_right, right_to_left), truncation);
        const auto term = hn::ShiftRight<4>(hn::Mul(bt, weight));
        hn::StoreU(hn::Add(hn::LoadU(d16, out + k), term), d16, out + k);
      }
    }
  }
  // Disparities whose right pixel leaves the image: x - min_disparity - k < 0 or >= width.
  const T max_cost = static_cast<T>(ctx.max_cost);
  const int num = in.num_disparities;
  const int first_left_out = std::max(0, x - in.min_disparity + 1);
  const int last_right_out = std::min(num, x - in.min_disparity - in.width + 1);
  if (first_left_out < num || last_right_out > 0) {
    // Lanes k >= first_left_out or k < last_right_out, a vector at a time (lanes >= num are
    // unspecified and may take max_cost too).
    const hn::ScalableTag<T> dt;
    const int nt = static_cast<int>(hn::Lanes(dt));
    const auto max_v = hn::Set(dt, max_cost);
    for (int k = 0; k < padded; k += nt) {
      const size_t inside_left = static_cast<size_t>(std::clamp(first_left_out - k, 0, nt));
      const size_t outside_right = static_cast<size_t>(std::clamp(last_right_out - k, 0, nt));
      if (inside_left == static_cast<size_t>(nt) && outside_right == 0) continue;
      const auto out_of_image =
          hn::Or(hn::Not(hn::FirstN(dt, inside_left)), hn::FirstN(dt, outside_right));
      hn::StoreU(hn::IfThenElse(out_of_image, max_v, hn::LoadU(dt, out + k)), dt, out + k);
    }
  }
}

void MatchingCostRowImpl(const CostInput& in, int y, uint16_t* out) {
  const int padded = PaddedDisparities(in.num_disparities);
  AlignedVector<uint64_t> census_reversed;
  AlignedVector<uint16_t> bt_reversed, bt_left;
  CostRowContext ctx;
  PrepareCostRow(in, y, padded, &census_reversed, &bt_reversed, &bt_left, nullptr, &ctx);
  for (int x = 0; x < in.width; ++x)
    PixelCost<uint16_t>(ctx, x, out + static_cast<size_t>(x) * padded);
}

// ------------------------------------------------------------------------------------------
// aggregation Path costs are uint8 when MaxMatchingCost + P2 <= 255 (census without BT and P2 <=
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

// Smallest lane of a uint8 or uint16 vector (Highway 1.0.3 has no MinOfLanes for uint8). On x86
// the vector is folded to 128 bits and finished with PHMINPOSUW (short latency: the horizontal path
// waits for this minimum at every pixel).
#if HWY_ARCH_X86 && HWY_TARGET <= HWY_SSE4
template <class D, class V>
HWY_INLINE auto FoldTo128(D d, V v) {
  if constexpr (hn::MaxLanes(d) * sizeof(hn::TFromD<D>) > 16) {
    const hn::Half<D> dh;
    return FoldTo128(dh, hn::Min(hn::LowerHalf(dh, v), hn::UpperHalf(dh, v)));
  } else {
    return v;
  }
}
template <class D, class V>
HWY_INLINE hn::TFromD<D> SmallestLane(D d, V v) {
  __m128i x = FoldTo128(d, v).raw;
  if constexpr (sizeof(hn::TFromD<D>) == 1) x = _mm_min_epu8(x, _mm_srli_epi16(x, 8));
  return static_cast<hn::TFromD<D>>(_mm_cvtsi128_si32(_mm_minpos_epu16(x)) & 0xFFFF);
}
#else
template <class D, class V>
HWY_INLINE hn::TFromD<D> SmallestLane(D d, V v) {
  if constexpr (sizeof(hn::TFromD<D>) == 1) {
    const hn::Repartition<uint16_t, D> d16;
    const auto pairs = hn::BitCast(d16, v);
    const auto m = hn::Min(hn::And(pairs, hn::Set(d16, uint16_t{0xFF})), hn::ShiftRight<8>(pairs));
    return static_cast<uint8_t>(hn::GetLane(hn::MinOfLanes(d16, m)));
  } else {
    return hn::GetLane(hn::MinOfLanes(d, v));
  }
}
#endif

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

// -------------------------------------------------------------------------------------
// winner-takes-all
//
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

// ------------------------------------------------------------------------------------------
// 3×3 median over valid neighbours. The nine values (invalid ones and those outside the image as
// kSgmInvalidFixed = INT16_MIN, which sorts first) go through a 25-comparator sorting network; with
// m invalid values the lower median of the 9 - m valid ones is sorted element m + (8 - m) / 2.
// `rows` holds three rows of width + 2 values (the row above, the row, the row below; replicated
// nothing: the two border columns and missing rows are INT16_MIN) plus one vector of slack.
void MedianValid3x3RowImpl(const int16_t* above, const int16_t* row, const int16_t* below,
                           int width, int16_t* out) {
  const hn::ScalableTag<int16_t> d;
  using V = hn::Vec<decltype(d)>;
  const int n = static_cast<int>(hn::Lanes(d));
  const V invalid = hn::Set(d, kSgmInvalidFixed);
  const V eight = hn::Set(d, int16_t{8});
  alignas(64) int16_t tail[64];
  for (int x = 0; x < width; x += n) {
    // Element (r, c) of the window of output pixel x is padded row r at x + c.
    V v[9] = {hn::LoadU(d, above + x), hn::LoadU(d, above + x + 1), hn::LoadU(d, above + x + 2),
              hn::LoadU(d, row + x),   hn::LoadU(d, row + x + 1),   hn::LoadU(d, row + x + 2),
              hn::LoadU(d, below + x), hn::LoadU(d, below + x + 1), hn::LoadU(d, below + x + 2)};
    const V centre = v[4];
    V missing = hn::Zero(d);  // number of invalid values (VecFromMask is -1 per true lane)
    for (int i = 0; i < 9; ++i)
      missing = hn::Sub(missing, hn::VecFromMask(d, hn::Eq(v[i], invalid)));
    static constexpr int kNetwork[25][2] = {{0, 3}, {1, 7}, {2, 5}, {4, 8}, {0, 7}, {2, 4}, {3, 8},
                                            {5, 6}, {0, 2}, {1, 3}, {4, 5}, {7, 8}, {1, 4}, {3, 6},
                                            {5, 7}, {0, 1}, {2, 4}, {3, 5}, {6, 8}, {2, 3}, {4, 5},
                                            {6, 7}, {1, 2}, {3, 4}, {5, 6}};
    for (const auto& [a, b] : kNetwork) {
      const V lo = hn::Min(v[a], v[b]);
      v[b] = hn::Max(v[a], v[b]);
      v[a] = lo;
    }
    const V index = hn::Add(missing, hn::ShiftRight<1>(hn::Sub(eight, missing)));
    V median = v[0];
    for (int i = 1; i < 9; ++i) {
      median = hn::IfThenElse(hn::Eq(index, hn::Set(d, static_cast<int16_t>(i))), v[i], median);
    }
    median = hn::IfThenElse(hn::Eq(centre, invalid), invalid, median);
    if (x + n <= width) {
      hn::StoreU(median, d, out + x);
    } else {
      hn::Store(median, d, tail);
      std::copy(tail, tail + (width - x), out + x);
    }
  }
}

}  // namespace HWY_NAMESPACE
}  // namespace linesight::detail
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace linesight::detail {

HWY_EXPORT(TargetNameImpl);
HWY_EXPORT(CensusRowsImpl);
HWY_EXPORT(MatchingCostRowImpl);
HWY_EXPORT(SweepImpl);
HWY_EXPORT(WinnerTakesAllRowImpl);
HWY_EXPORT(MedianValid3x3RowImpl);

std::string DispatchedTargetName() { return HWY_DYNAMIC_DISPATCH(TargetNameImpl)(); }

void CensusTransform(const cv::Mat& gray, int window_width, int window_height, int row_begin,
                     int row_end, uint64_t* codes) {
  LS_CHECK(gray.type() == CV_8UC1);
  LS_CHECK(window_width % 2 == 1 && window_height % 2 == 1);
  LS_CHECK(window_width * window_height - 1 <= 64);
  if (row_begin >= row_end) return;
  const int w = gray.cols, h = gray.rows;
  const int rx = window_width / 2, ry = window_height / 2;
  std::vector<int> offset_dy, offset_dx;
  for (int dy = -ry; dy <= ry; ++dy) {
    for (int dx = -rx; dx <= rx; ++dx) {
      if (dy == 0 && dx == 0) continue;
      offset_dy.push_back(dy);
      offset_dx.push_back(dx);
    }
  }
  const size_t stride = static_cast<size_t>(w) + 2 * rx + 64 + 64;
  const int rows = row_end - row_begin + 2 * ry;
  AlignedVector<uint8_t> padded(stride * rows, 0);
  for (int r = 0; r < rows; ++r) {
    const int src_y = std::clamp(row_begin - ry + r, 0, h - 1);
    const uint8_t* src = gray.ptr<uint8_t>(src_y);
    uint8_t* dst = padded.data() + static_cast<size_t>(r) * stride;
    for (int i = 0; i < rx; ++i) {
      dst[i] = src[0];
      dst[rx + w + i] = src[w - 1];
    }
    std::memcpy(dst + rx, src, static_cast<size_t>(w));
  }
  AlignedVector<uint8_t> planes(8 * stride, 0);
  HWY_DYNAMIC_DISPATCH(CensusRowsImpl)
  (padded.data(), stride, w, offset_dy.data(), offset_dx.data(), static_cast<int>(offset_dy.size()),
   rx, ry, row_begin, row_end, planes.data(), codes);
}

int MaxMatchingCost(const CostInput& input) {
  return input.census_bits + (input.bt_weight * 2 * input.bt_truncation) / 16;
}

void MatchingCostRow(const CostInput& input, int y, uint16_t* out) {
  HWY_DYNAMIC_DISPATCH(MatchingCostRowImpl)(input, y, out);
}

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

void WinnerTakesAllRow(const uint16_t* sum_row, int width, int num_disparities, int min_disparity,
                       WtaRow out, uint16_t* right_cost_scratch) {
  HWY_DYNAMIC_DISPATCH(WinnerTakesAllRowImpl)
  (sum_row, width, num_disparities, min_disparity, out, right_cost_scratch);
}

void MedianValid3x3(const cv::Mat& src, cv::Mat& dst, int row_begin, int row_end) {
  LS_CHECK(src.type() == CV_16SC1 && dst.type() == CV_16SC1 && src.size() == dst.size());
  const int w = src.cols, h = src.rows;
  // Three padded rows (INT16_MIN border columns) plus a vector of slack for the last loads.
  const size_t stride = static_cast<size_t>(w) + 2 + 64;
  AlignedVector<int16_t> rows(3 * stride, kSgmInvalidFixed);
  const auto fill = [&](int slot, int y) {
    int16_t* r = rows.data() + slot * stride;
    if (y < 0 || y >= h) {
      std::fill(r, r + stride, kSgmInvalidFixed);
    } else {
      r[0] = kSgmInvalidFixed;
      std::copy(src.ptr<int16_t>(y), src.ptr<int16_t>(y) + w, r + 1);
      std::fill(r + 1 + w, r + stride, kSgmInvalidFixed);
    }
  };
  const auto median_row = HWY_DYNAMIC_DISPATCH(MedianValid3x3RowImpl);
  for (int y = row_begin; y < row_end; ++y) {
    // Slot of padded row y is y mod 3; refill what the previous row did not leave behind.
    for (int yy = y - 1; yy <= y + 1; ++yy) {
      if (y == row_begin || yy == y + 1) fill((yy + 3) % 3, yy);
    }
    median_row(rows.data() + ((y + 2) % 3) * stride, rows.data() + (y % 3) * stride,
               rows.data() + ((y + 1) % 3) * stride, w, dst.ptr<int16_t>(y));
  }
}

}  // namespace linesight::detail
#endif  // HWY_ONCE
