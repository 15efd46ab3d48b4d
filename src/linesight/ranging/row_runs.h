// SIMD kernel of the run dilation behind DilateEllipse, ErodeEllipse and NearerThan
// (thin_structures.h): one output row of a binary dilation by an element made of centred runs.
#pragma once

#include <cstdint>

namespace linesight::detail {

// out[x] = 0xff when near[j][x] <= reach[j] for some j < count, else 0, for x < cols. The
// dilation calls it once per output row with, for each column dx of the element, near[j] = the
// row of vertical distances (saturated at 255) to each column's nearest set pixel, shifted by dx,
// and reach[j] = that column's half-height. Integer only: every Highway target gives the same
// bytes (thin_structures_test checks the morphology built on it against OpenCV's on awkward
// sizes).
void OrRowRuns(const std::uint8_t* const* near, const std::uint8_t* reach, int count, int cols,
               std::uint8_t* out);

}  // namespace linesight::detail
