// The matching cost of one pixel over all its disparities (CostInput, sgm_stages.h), shared by the
// matching-cost kernel (sgm_matching_cost.cc) and path aggregation (sgm_aggregation.cc), which
// recomputes the costs of each row instead of storing a cost volume. Compiled for the Highway
// target of the file that includes it.

// Per-target include guard (Highway's foreach_target re-includes this header once per target).
#if defined(LINESIGHT_STEREO_SGM_COST_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef LINESIGHT_STEREO_SGM_COST_INL_H_
#undef LINESIGHT_STEREO_SGM_COST_INL_H_
#else
#define LINESIGHT_STEREO_SGM_COST_INL_H_
#endif

#include <algorithm>
#include <bit>
#include <cstddef>
#include <cstdint>

#include <hwy/highway.h>

#include "linesight/stereo/sgm_stages.h"

HWY_BEFORE_NAMESPACE();
namespace linesight::detail {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// Per-row context of the matching cost: the right census and BT values stored in
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

inline void PrepareCostRow(const CostInput& in, int y, int padded,
                           AlignedVector<uint64_t>* census_reversed,
                           AlignedVector<uint16_t>* bt_reversed, AlignedVector<uint16_t>* bt_left,
                           AlignedVector<uint8_t>* planes_reversed, CostRowContext* ctx) {
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

}  // namespace HWY_NAMESPACE
}  // namespace linesight::detail
HWY_AFTER_NAMESPACE();

#endif  // LINESIGHT_STEREO_SGM_COST_INL_H_
