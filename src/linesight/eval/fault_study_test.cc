#include "linesight/eval/fault_study.h"

#include <string>

#include <gtest/gtest.h>

#include "linesight/core/error.h"

namespace linesight {
namespace {

TEST(FaultStudyOptionsTest, DefaultsAreValidAndBadValuesAreNamed) {
  FaultStudyOptions o;
  EXPECT_NO_THROW(o.Check());
  EXPECT_EQ(o.sequence.num_defects, 4);
  EXPECT_EQ(o.sequence.tilted_damper_share, 0.5);
  o.seeds.clear();
  EXPECT_THROW(o.Check(), OptionError);
  o = {};
  o.sequence.tilted_damper_share = 2;
  try {
    o.Check();
    FAIL() << "expected an OptionError";
  } catch (const OptionError& e) {
    EXPECT_NE(std::string(e.what()).find("tilted_damper_share"), std::string::npos) << e.what();
  }
}

// Tuning seed 25 (its first obstacle a damper tilted by 19 deg), every 40th frame: the tilted
// damper is scored as a truth of its own type and found, and the report's figures agree.
TEST(FaultStudyTest, ScoresTiltedDampersWithTheDefects) {
  FaultStudyOptions o;
  o.seeds = {25};
  o.frame_step = 40;
  const FaultStudyReport r = RunFaultStudy(o);
  EXPECT_EQ(r.frames, FaultStudyFrames(o));
  ASSERT_EQ(r.types.back(), "damper_tilted");
  const FaultRates& tilted = r.by_type.back();
  ASSERT_GT(tilted.scored, 0);
  EXPECT_EQ(tilted.matched, tilted.scored);
  EXPECT_EQ(tilted.typed_right, tilted.matched);
  int scored = 0, matched = 0;
  for (const FaultRates& rates : r.by_type) {
    scored += rates.scored;
    matched += rates.matched;
  }
  EXPECT_EQ(scored, r.all.scored);
  EXPECT_EQ(matched, r.all.matched);
  // Every measured damper is this sequence's tilted one, read within 6 deg.
  ASSERT_FALSE(r.damper_roll_errors_deg.empty());
  EXPECT_LT(r.RollErrorQuantile(1.0), 6.0);
  EXPECT_EQ(r.sound_damper_checks, 0);
  const nlohmann::json j = r.ToJson();
  EXPECT_EQ(j["types"]["damper_tilted"]["scored"], tilted.scored);
  EXPECT_EQ(j["damper_roll_checks"], r.damper_roll_errors_deg.size());
  EXPECT_NE(r.ToMarkdown().find("| damper_tilted |"), std::string::npos);
}

}  // namespace
}  // namespace linesight
