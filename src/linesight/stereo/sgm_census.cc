// SIMD kernel of the SGM census transform (CensusTransform, sgm_stages.h), compiled once per
// Highway target (foreach_target) and dispatched at run time.
// The kernel is defined in integers only, so every target gives bit-identical results;
// sgm_reference_test.cc checks it against its naive scalar reference (sgm_reference.h) on every
// target the CPU supports.

#include <algorithm>
#include <cstring>
#include <vector>

#include "linesight/core/error.h"
#include "linesight/stereo/sgm_stages.h"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "linesight/stereo/sgm_census.cc"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace linesight::detail {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// Every SGM kernel file is compiled for the same target list, so this dispatch names the target of
// all of them.
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

}  // namespace HWY_NAMESPACE
}  // namespace linesight::detail
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace linesight::detail {

HWY_EXPORT(TargetNameImpl);
HWY_EXPORT(CensusRowsImpl);

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

}  // namespace linesight::detail
#endif  // HWY_ONCE
