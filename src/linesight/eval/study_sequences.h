// The moving sequences a study renders, shared by the sequence study (sequence_study.h) and the
// fault study (fault_study.h): both options carry `sequence` (sim::PowerLineSequenceOptions) and
// `max_frames`.
#pragma once

#include <algorithm>
#include <cstdint>

#include "linesight/sim/power_line_sequence.h"

namespace linesight {

// The sequence of `seed` with the study's sequence options.
template <typename StudyOptions>
sim::PowerLineSequence StudySequence(const StudyOptions& options, std::uint64_t seed) {
  sim::PowerLineSequenceOptions o = options.sequence;
  o.seed = seed;
  return sim::PowerLineSequence(o);
}

// The frames of `sequence` the study scores (before the frame step): all of them, or the first
// max_frames when that is > 0.
template <typename StudyOptions>
int StudyFrames(const StudyOptions& options, const sim::PowerLineSequence& sequence) {
  return options.max_frames > 0 ? std::min(options.max_frames, sequence.size()) : sequence.size();
}

}  // namespace linesight
