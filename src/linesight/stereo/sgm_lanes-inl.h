// Lane reductions shared by the SGM kernels of path aggregation and winner-takes-all, compiled
// for the Highway target of the file that includes it (sgm_aggregation.cc,
// sgm_winner_takes_all.cc).

// Per-target include guard (Highway's foreach_target re-includes this header once per target).
#if defined(LINESIGHT_STEREO_SGM_LANES_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef LINESIGHT_STEREO_SGM_LANES_INL_H_
#undef LINESIGHT_STEREO_SGM_LANES_INL_H_
#else
#define LINESIGHT_STEREO_SGM_LANES_INL_H_
#endif

#include <cstdint>

#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace linesight::detail {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

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

}  // namespace HWY_NAMESPACE
}  // namespace linesight::detail
HWY_AFTER_NAMESPACE();

#endif  // LINESIGHT_STEREO_SGM_LANES_INL_H_
