// The moving power-line sequence as the line tests render it.
#pragma once

#include <cstdint>

#include "linesight/sim/power_line_sequence.h"

namespace linesight::testing {

// The sequence of `seed` at supersampling 1 (fast enough for tests; the line stages see the same
// geometry and texture as at the default supersampling).
inline sim::PowerLineSequenceOptions FastSequence(std::uint64_t seed) {
  sim::PowerLineSequenceOptions o;
  o.seed = seed;
  o.scene.sensor.supersampling = 1;
  return o;
}

}  // namespace linesight::testing
