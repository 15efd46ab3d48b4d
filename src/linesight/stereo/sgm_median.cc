// SIMD kernel of the SGM 3×3 median over valid neighbours (MedianValid3x3, sgm_stages.h), compiled
// once per Highway target (foreach_target) and dispatched at run time.
// The kernel is defined in integers only, so every target gives bit-identical results;
// sgm_reference_test.cc checks it against its naive scalar reference (sgm_reference.h) on every
// target the CPU supports.

#include <algorithm>
#include <cstdint>

#include "linesight/core/error.h"
#include "linesight/stereo/sgm_stages.h"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "linesight/stereo/sgm_median.cc"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace linesight::detail {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

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

HWY_EXPORT(MedianValid3x3RowImpl);

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
