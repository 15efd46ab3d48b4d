#include "linesight/core/progress.h"

#include <gtest/gtest.h>

namespace linesight {
namespace {

TEST(ProgressBar, RendersFractionAndEta) {
  EXPECT_EQ(ProgressBar::Render("eval", 1, 4, 2.0, "tsukuba", 8),
            "eval [##......] 1/4 2.0s eta 6s  tsukuba");
}

TEST(ProgressBar, ClampsAndHasNoEtaWhenDone) {
  EXPECT_EQ(ProgressBar::Render("x", 9, 4, 1.0, "", 4), "x [####] 4/4 1.0s");
  EXPECT_EQ(ProgressBar::Render("x", 0, 0, 0.0, "", 4), "x [....] 0/1 0.0s");
}

TEST(ProgressBar, DisabledBarCountsSilently) {
  ProgressBar bar(10, "quiet", false);
  bar.Advance(3);
  bar.Advance();
  EXPECT_EQ(bar.done(), 4);
  EXPECT_FALSE(bar.enabled());
}

}  // namespace
}  // namespace linesight
