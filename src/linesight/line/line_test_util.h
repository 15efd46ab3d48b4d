// The moving power-line sequence and the matching chain as the line tests use them.
#pragma once

#include <cstdint>

#include "linesight/line/line_obstacles.h"
#include "linesight/ranging/pipeline.h"
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

// The chain the line stages run on (LineMatcherParams), on one thread.
inline RangingPipelineOptions LineChainOnOneThread() {
  RangingPipelineOptions o;
  o.threads = 1;
  o.params = LineMatcherParams(o.method, o.params);
  return o;
}

}  // namespace linesight::testing
