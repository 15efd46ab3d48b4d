#include "linesight/eval/sequence_study.h"

#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "linesight/core/error.h"

namespace linesight {
namespace {

namespace fs = std::filesystem;

TEST(SequenceStudyOptionsTest, DefaultsAreValidAndBadValuesAreNamed) {
  SequenceStudyOptions o;
  EXPECT_NO_THROW(o.Check());
  EXPECT_EQ(o.sequence.scene.sensor.supersampling, 1);
  o.seeds.clear();
  EXPECT_THROW(o.Check(), OptionError);
  o = {};
  o.bin_edges = {1.0, 1.0};
  EXPECT_THROW(o.Check(), OptionError);
  o = {};
  o.min_arc_m = 3;
  o.max_arc_m = 2;
  try {
    o.Check();
    FAIL() << "expected an OptionError";
  } catch (const OptionError& e) {
    EXPECT_NE(std::string(e.what()).find("max_arc_m"), std::string::npos) << e.what();
  }
}

TEST(SequenceStudyOptionsTest, CountsTheFramesItProcesses) {
  SequenceStudyOptions o;
  o.seeds = {3, 5};
  sim::PowerLineSequenceOptions s = o.sequence;
  s.seed = 3;
  const int n3 = sim::PowerLineSequence(s).size();
  s.seed = 5;
  const int n5 = sim::PowerLineSequence(s).size();
  o.frame_step = 7;
  EXPECT_EQ(SequenceStudyFrames(o), (n3 + 6) / 7 + (n5 + 6) / 7);
  o.max_frames = 10;
  EXPECT_EQ(SequenceStudyFrames(o), 2 * 2);
}

// Tuning seed 3, every 40th frame, true calibration: the obstacles on the line are found with low
// error, nothing false is reported, and the report's figures agree with each other.
TEST(SequenceStudyTest, ScoresASequenceEndToEnd) {
  SequenceStudyOptions o;
  o.seeds = {3};
  o.frame_step = 40;
  o.calibration = StudyCalibration::kTrue;
  const SequenceStudyReport r = RunSequenceStudy(o);
  EXPECT_EQ(r.frames, SequenceStudyFrames(o));
  EXPECT_NEAR(r.duration_s, r.frames * 40 / o.sequence.fps, 1e-9);
  ASSERT_GT(r.all.scored, 0);
  EXPECT_GE(r.all.recall(), 0.5);
  EXPECT_GE(r.all.precision(), 0.9);
  EXPECT_GE(r.all.type_accuracy(), 0.8);
  EXPECT_LT(r.arc.median, 0.03);
  EXPECT_EQ(r.no_conductor_frames, 0);
  int scored = 0, matched = 0;
  for (const SequenceRateStats& s : r.by_type) {
    scored += s.scored;
    matched += s.matched;
  }
  EXPECT_EQ(scored, r.all.scored);
  EXPECT_EQ(matched, r.all.matched);
  // Every miss has one cause.
  for (const SequenceRateStats& s : r.by_type) {
    EXPECT_EQ(s.missed_no_conductor + s.missed_off_distance + s.missed_covered + s.missed_not_found,
              s.scored - s.matched);
  }
  EXPECT_EQ(r.all.missed_no_conductor, 0);
  EXPECT_EQ(static_cast<int>(r.samples.size()), r.all.matched);
  EXPECT_EQ(r.arc.count, r.all.matched);
  ASSERT_EQ(r.bins.size(), o.bin_edges.size() - 1);
  ASSERT_FALSE(r.obstacles.empty());
  for (const SequenceObstacle& ob : r.obstacles) {
    EXPECT_LE(ob.detected_frames, ob.scored_frames);
    EXPECT_LE(ob.typed_frames, ob.detected_frames);
  }
  const std::string md = r.ToMarkdown();
  EXPECT_NE(md.find("| all |"), std::string::npos);
  EXPECT_NE(md.find("**seeds 3 are tuning seeds**"), std::string::npos) << md;
  const nlohmann::json j = r.ToJson();
  EXPECT_EQ(j["frames"], r.frames);
  EXPECT_EQ(j["calibration"], "true");
  EXPECT_TRUE(j["ranging_settings"].is_object());
  const fs::path dir = fs::path(::testing::TempDir()) / "sequence_study_plots";
  fs::remove_all(dir);
  r.WritePlots(dir);
  std::ifstream svg(dir / "sequences.svg");
  std::stringstream text;
  text << svg.rdbuf();
  EXPECT_NE(text.str().find("<svg"), std::string::npos);
}

}  // namespace
}  // namespace linesight
