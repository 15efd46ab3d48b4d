// SIMD kernel of the superpixel assignment (grey features), compiled once per Highway target and
// dispatched at run time. It evaluates exactly the scalar expression of every distance (this file
// is compiled with -ffp-contract=off: no fused multiply-add), so every target assigns the same
// labels; superpixels_test.cc checks it against a naive scalar reference for every target.

#include <algorithm>
#include <cstdint>
#include <cstring>

#include "linesight/stereo/superpixels.h"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "linesight/stereo/superpixel_kernels.cc"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace linesight::detail {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// Rows [ya, yb) x columns [xa, xb) of one quarter cell against its four candidate centres (x, y,
// grey value; ids in increasing order, ties to the smaller index).
void AssignGreyBlockImpl(const uint8_t* features, size_t feature_stride, int width, int ya, int yb,
                         int xa, int xb, const int32_t* ids, const float* cx, const float* cy,
                         const float* cf, float spatial_weight, int32_t* labels,
                         size_t label_stride) {
  const hn::CappedTag<float, 8> df;
  const hn::Rebind<int32_t, decltype(df)> di;
  const hn::Rebind<uint8_t, decltype(df)> d8;
  const int n = static_cast<int>(hn::Lanes(df));
  const auto weight = hn::Set(df, spatial_weight);
  alignas(64) uint8_t pixels[64] = {};
  alignas(64) int32_t out[64];
  hn::Vec<decltype(df)> centre_x[4], centre_f[4];
  for (int i = 0; i < 4; ++i) {
    centre_x[i] = hn::Set(df, cx[i]);
    centre_f[i] = hn::Set(df, cf[i]);
  }
  const auto ids0 = hn::Set(di, ids[0]), ids1 = hn::Set(di, ids[1]);
  const auto ids2 = hn::Set(di, ids[2]), ids3 = hn::Set(di, ids[3]);
  for (int y = ya; y < yb; ++y) {
    const uint8_t* f = features + static_cast<size_t>(y) * feature_stride;
    int32_t* l = labels + static_cast<size_t>(y) * label_stride;
    hn::Vec<decltype(df)> row_term[4];
    for (int i = 0; i < 4; ++i) {
      const float dy = static_cast<float>(y) - cy[i];
      row_term[i] = hn::Set(df, spatial_weight * dy * dy);
    }
    for (int x = xa; x < xb; x += n) {
      const int count = std::min(n, xb - x);
      const uint8_t* source = f + x;
      if (x + n > width) {  // the last columns of the row: no full vector to load
        std::memcpy(pixels, f + x, static_cast<size_t>(count));
        source = pixels;
      }
      const auto value = hn::ConvertTo(df, hn::PromoteTo(di, hn::LoadU(d8, source)));
      const auto px = hn::ConvertTo(df, hn::Iota(di, x));
      hn::Vec<decltype(df)> dist[4];
      for (int i = 0; i < 4; ++i) {
        // Scalar form: row_term + spatial_weight * dx * dx, then += dc * dc.
        const auto dx = hn::Sub(px, centre_x[i]);
        const auto dc = hn::Sub(value, centre_f[i]);
        dist[i] = hn::Add(hn::Add(row_term[i], hn::Mul(hn::Mul(weight, dx), dx)), hn::Mul(dc, dc));
      }
      const auto first_pair = hn::Le(dist[0], dist[1]);
      const auto best01 = hn::IfThenElse(first_pair, dist[0], dist[1]);
      const auto id01 = hn::IfThenElse(hn::RebindMask(di, first_pair), ids0, ids1);
      const auto second_pair = hn::Le(dist[2], dist[3]);
      const auto best23 = hn::IfThenElse(second_pair, dist[2], dist[3]);
      const auto id23 = hn::IfThenElse(hn::RebindMask(di, second_pair), ids2, ids3);
      const auto id = hn::IfThenElse(hn::RebindMask(di, hn::Le(best01, best23)), id01, id23);
      hn::Store(id, di, out);
      std::copy(out, out + count, l + x);
    }
  }
}

}  // namespace HWY_NAMESPACE
}  // namespace linesight::detail
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace linesight::detail {

HWY_EXPORT(AssignGreyBlockImpl);

void AssignGreyBlock(const uint8_t* features, size_t feature_stride, int width, int ya, int yb,
                     int xa, int xb, const int32_t* ids, const float* cx, const float* cy,
                     const float* cf, float spatial_weight, int32_t* labels, size_t label_stride) {
  HWY_DYNAMIC_DISPATCH(AssignGreyBlockImpl)
  (features, feature_stride, width, ya, yb, xa, xb, ids, cx, cy, cf, spatial_weight, labels,
   label_stride);
}

}  // namespace linesight::detail
#endif  // HWY_ONCE
