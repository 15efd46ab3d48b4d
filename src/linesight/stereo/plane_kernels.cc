// SIMD kernel of the robust plane fit, compiled once per Highway target and dispatched at run time.
// It evaluates exactly the scalar expression (this file is compiled with -ffp-contract=off: no
// fused multiply-add), so every target counts the same inliers; plane_refinement_test.cc checks it
// against the scalar form for every target.

#include <cstddef>

#include "linesight/stereo/plane_refinement.h"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "linesight/stereo/plane_kernels.cc"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace linesight::detail {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

int CountPlaneInliersImpl(const double* x, const double* y, const double* d, size_t padded,
                          double a, double b, double c, double threshold) {
  const hn::ScalableTag<double> dd;
  const size_t n = hn::Lanes(dd);
  const auto va = hn::Set(dd, a), vb = hn::Set(dd, b), vc = hn::Set(dd, c);
  const auto limit = hn::Set(dd, threshold);
  size_t count = 0;
  for (size_t i = 0; i < padded; i += n) {
    // (a * x + b * y + c) - d, as DisparityPlane::At(x, y) - d.
    const auto at =
        hn::Add(hn::Add(hn::Mul(va, hn::LoadU(dd, x + i)), hn::Mul(vb, hn::LoadU(dd, y + i))), vc);
    const auto residual = hn::Sub(at, hn::LoadU(dd, d + i));
    count += hn::CountTrue(dd, hn::Le(hn::Abs(residual), limit));
  }
  return static_cast<int>(count);
}

}  // namespace HWY_NAMESPACE
}  // namespace linesight::detail
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace linesight::detail {

HWY_EXPORT(CountPlaneInliersImpl);

int CountPlaneInliers(const double* x, const double* y, const double* d, size_t padded,
                      const DisparityPlane& plane, double threshold) {
  return HWY_DYNAMIC_DISPATCH(CountPlaneInliersImpl)(x, y, d, padded, plane.a, plane.b, plane.c,
                                                     threshold);
}

}  // namespace linesight::detail
#endif  // HWY_ONCE
