#include "linesight/core/error.h"

#include <gtest/gtest.h>

namespace linesight {
namespace {

TEST(CheckOption, PassesWhenRuleHolds) { EXPECT_NO_THROW(CheckOption(true, "Foo.bar", 3, "x")); }

TEST(CheckOption, MessageNamesFieldValueAndRule) {
  try {
    CheckOption(false, "SgmOptions.p1", -2, "must be >= 0");
    FAIL() << "no throw";
  } catch (const OptionError& e) {
    EXPECT_STREQ(e.what(), "SgmOptions.p1 = -2: must be >= 0");
  }
}

TEST(CheckOption, OptionErrorIsInputError) {
  EXPECT_THROW(CheckOption(false, "A.b", 1.5, "rule"), InputError);
}

TEST(LsCheckDeathTest, AbortsWithFileAndLine) {
  EXPECT_DEATH(LS_CHECK_MSG(1 + 1 == 3, "value {}", 7),
               "error_test.cc:[0-9]+: internal check failed: 1 \\+ 1 == 3: value 7");
}

}  // namespace
}  // namespace linesight
