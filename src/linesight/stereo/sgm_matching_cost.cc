// SIMD kernel of the SGM matching cost (MatchingCostRow, sgm_stages.h; the per-pixel cost itself is
// in sgm_cost-inl.h), compiled once per Highway target (foreach_target) and dispatched at run time.
// The kernel is defined in integers only, so every target gives bit-identical results;
// sgm_reference_test.cc checks it against its naive scalar reference (sgm_reference.h) on every
// target the CPU supports.

#include <cstdint>

#include "linesight/stereo/sgm_stages.h"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "linesight/stereo/sgm_matching_cost.cc"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include "linesight/stereo/sgm_cost-inl.h"

HWY_BEFORE_NAMESPACE();
namespace linesight::detail {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

void MatchingCostRowImpl(const CostInput& in, int y, uint16_t* out) {
  const int padded = PaddedDisparities(in.num_disparities);
  AlignedVector<uint64_t> census_reversed;
  AlignedVector<uint16_t> bt_reversed, bt_left;
  CostRowContext ctx;
  PrepareCostRow(in, y, padded, &census_reversed, &bt_reversed, &bt_left, nullptr, &ctx);
  for (int x = 0; x < in.width; ++x)
    PixelCost<uint16_t>(ctx, x, out + static_cast<size_t>(x) * padded);
}

}  // namespace HWY_NAMESPACE
}  // namespace linesight::detail
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace linesight::detail {

HWY_EXPORT(MatchingCostRowImpl);

int MaxMatchingCost(const CostInput& input) {
  return input.census_bits + (input.bt_weight * 2 * input.bt_truncation) / 16;
}

void MatchingCostRow(const CostInput& input, int y, uint16_t* out) {
  HWY_DYNAMIC_DISPATCH(MatchingCostRowImpl)(input, y, out);
}

}  // namespace linesight::detail
#endif  // HWY_ONCE
