// Test helper for options structs (CONVENTIONS.md §2): one boundary per call.
#pragma once

#include <gtest/gtest.h>

#include "linesight/core/error.h"

namespace linesight::testing {

// Default `Options` with `change` applied must fail Check() with `Error`.
template <typename Options, typename Error = OptionError, typename Change>
void ExpectCheckRejects(Change change) {
  Options options;
  change(options);
  EXPECT_THROW(options.Check(), Error);
}

}  // namespace linesight::testing
