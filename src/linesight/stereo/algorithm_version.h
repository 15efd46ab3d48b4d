// Versions of the matchers' algorithms, for caches of their results.
#pragma once

#include <string>

namespace linesight {

// Version of a method's algorithm (>= 1): part of the keys of eval's result cache
// (eval/result_cache.h), which reuses a stored result only for the same version. BUMP IT (the
// table in matcher.cc) WHENEVER A CHANGE ALTERS THE METHOD'S OUTPUT for the same settings and
// input; changes that keep the output bit-identical (speed-ups checked against the reference)
// keep it. Throws UsageError for an unknown name.
int MatcherAlgorithmVersion(const std::string& method);

}  // namespace linesight
