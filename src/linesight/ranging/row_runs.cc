// OrRowRuns (row_runs.h), compiled once per Highway target (foreach_target) and dispatched at run
// time.

#include "linesight/ranging/row_runs.h"

#include <cstddef>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "linesight/ranging/row_runs.cc"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace linesight::detail {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

void OrRowRunsImpl(const std::uint8_t* const* near, const std::uint8_t* reach, int count, int cols,
                   std::uint8_t* out) {
  const hn::ScalableTag<std::uint8_t> d;
  const size_t lanes = hn::Lanes(d), width = static_cast<size_t>(cols);
  size_t x = 0;
  // A vector of output bytes stays in a register while the element's rows are or-ed into it.
  for (; x + lanes <= width; x += lanes) {
    auto acc = hn::Zero(d);
    for (int j = 0; j < count; ++j) {
      // near <= width, as min(near, width) == near (unsigned bytes have no ordered compare on
      // every target).
      const auto v = hn::LoadU(d, near[j] + x);
      const auto run = hn::Eq(hn::Min(v, hn::Set(d, reach[j])), v);
      acc = hn::Or(acc, hn::VecFromMask(d, run));
    }
    hn::StoreU(acc, d, out + x);
  }
  for (; x < width; ++x) {
    std::uint8_t o = 0;
    for (int j = 0; j < count; ++j) o |= near[j][x] <= reach[j] ? 0xff : 0;
    out[x] = o;
  }
}

}  // namespace HWY_NAMESPACE
}  // namespace linesight::detail
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace linesight::detail {

HWY_EXPORT(OrRowRunsImpl);

void OrRowRuns(const std::uint8_t* const* near, const std::uint8_t* reach, int count, int cols,
               std::uint8_t* out) {
  HWY_DYNAMIC_DISPATCH(OrRowRunsImpl)(near, reach, count, cols, out);
}

}  // namespace linesight::detail
#endif  // HWY_ONCE
