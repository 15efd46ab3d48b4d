#include "linesight/eval/sweep.h"

#include <gtest/gtest.h>

#include "linesight/core/error.h"
#include "linesight/eval/eval_stereo.h"
#include "linesight/eval/synthetic_scenes_test_util.h"
#include "linesight/stereo/matcher.h"

namespace linesight {
namespace {

TEST(SweepTest, DefaultParametersOfSgbmMatchTheStudy) {
  const auto params = DefaultSweepParameters("sgbm");
  ASSERT_EQ(params.size(), 3u);
  EXPECT_EQ(params[0].key, kSweepNumDisparitiesKey);
  EXPECT_EQ(params[0].values,
            (std::vector<std::string>{"16", "32", "48", "64", "80", "96", "112"}));
  EXPECT_EQ(params[0].centre, "64");
  EXPECT_EQ(params[1].key, "block");
  EXPECT_EQ(params[1].values, (std::vector<std::string>{"3", "5", "7", "9", "11"}));
  EXPECT_EQ(params[1].centre, "7");
  EXPECT_EQ(params[2].key, "uniqueness");
  EXPECT_EQ(params[2].values.size(), 11u);
  EXPECT_EQ(params[2].values.front(), "5");
  EXPECT_EQ(params[2].values.back(), "15");
  EXPECT_EQ(params[2].centre, "10");
  const auto isgm = DefaultSweepParameters("isgm");
  std::vector<std::string> keys;
  for (const auto& p : isgm) keys.push_back(p.key);
  EXPECT_EQ(keys, (std::vector<std::string>{kSweepNumDisparitiesKey, "p1", "p2", "superpixel_size",
                                            "plane_inlier"}));
  EXPECT_TRUE(DefaultSweepParameters("nonexistent").empty());
}

TEST(SweepTest, EveryDefaultSweepValueIsAValidSetting) {
  // A swept value the matcher rejects would abort `eval report` after minutes of work (isgm's
  // plane_inlier above its outlier threshold did).
  for (const std::string& method : MatcherNames()) {
    for (const SweepParameter& p : DefaultSweepParameters(method)) {
      if (p.key == kSweepNumDisparitiesKey) continue;
      for (const std::string& value : p.values) {
        MatcherOptions o;
        o.params = {{p.key, value}};
        EXPECT_NO_THROW(CreateMatcher(method, o)) << method << " " << p.key << "=" << value;
      }
    }
  }
  EXPECT_EQ(MethodsWithDefaultSweep(), MatcherNames());  // every matcher has a study
  const auto isgm = DefaultSweepParameters("isgm");
  EXPECT_EQ(isgm.back().key, "plane_inlier");
  EXPECT_GE(isgm.back().values.size(), 4u);
}

TEST(SweepTest, DefaultsValidAndBadOptionsRejected) {
  EXPECT_NO_THROW(SweepOptions().Check());
  SweepOptions bad_threads;
  bad_threads.threads = -1;
  EXPECT_THROW(bad_threads.Check(), OptionError);
  SweepOptions bad_centre;
  bad_centre.parameters = {{"sgbm", "block", {"3", "5"}, "7"}};
  EXPECT_THROW(bad_centre.Check(), OptionError);
}

TEST(SweepTest, OneRowPerValueAndCentreEqualsDirectEvalStereo) {
  testing::ScopedTempDir dir;
  const auto scenes = FindScenes(testing::WriteTwoSyntheticScenes(dir.path()));
  ASSERT_EQ(scenes.size(), 2u);
  SweepOptions options;
  options.methods = {"sgbm"};
  options.threads = 1;
  const SweepReport report = RunSweep(scenes, options);
  const auto params = DefaultSweepParameters("sgbm");
  ASSERT_EQ(report.curves.size(), params.size());
  for (size_t i = 0; i < params.size(); ++i) {
    ASSERT_EQ(report.curves[i].points.size(), params[i].values.size()) << params[i].key;
    for (size_t j = 0; j < params[i].values.size(); ++j) {
      EXPECT_EQ(report.curves[i].points[j].value, params[i].values[j]);
      EXPECT_EQ(report.curves[i].points[j].scenes, 2);
    }
  }
  EXPECT_EQ(report.bad_label, "bad-1.0 nonocc");

  // The same centre point through RunEvalStereo (the scenes' own search range is 64 = the centre).
  EvalStereoOptions eval;
  eval.methods = {"sgbm"};
  eval.threads = 1;
  eval.params = {{"sgbm.block", "7"}, {"sgbm.uniqueness", "10"}};
  const EvalStereoReport direct = RunEvalStereo(scenes, eval);
  ASSERT_EQ(direct.results.size(), 2u);
  double rmse = 0, bad = 0;
  for (const auto& r : direct.results) {
    ASSERT_EQ(r.num_disparities, 64);
    const PrimaryMetric primary = PrimaryMetricFor(r);
    bad += primary.value / 2;
    rmse += r.regions.at(primary.region).rmse / 2;
  }
  for (const SweepCurve& curve : report.curves) {
    const auto centre = std::find_if(curve.points.begin(), curve.points.end(),
                                     [&](const SweepPoint& p) { return p.value == curve.centre; });
    ASSERT_NE(centre, curve.points.end());
    EXPECT_DOUBLE_EQ(centre->bad, bad) << curve.key;
    EXPECT_DOUBLE_EQ(centre->rmse, rmse) << curve.key;
  }
  // The shifted texture is easy to match: where SGBM gives an estimate it is right (it leaves the
  // first num_disp columns empty, which the dense bad rate counts).
  EXPECT_LT(rmse, 0.5);
  EXPECT_LT(bad, 100.0 * 64 / 160 + 5);

  const std::string markdown = report.ToMarkdown();
  EXPECT_NE(markdown.find("#### block"), std::string::npos);
  EXPECT_NE(markdown.find("| 112 |"), std::string::npos);
  testing::ScopedTempDir plots;
  const auto written = report.WritePlots(plots.path());
  ASSERT_EQ(written.size(), 2u);
  for (const auto& name : written) EXPECT_TRUE(std::filesystem::exists(plots.path() / name));
  EXPECT_EQ(report.ToJson()["curves"].size(), 3u);
}

TEST(SweepTest, TooSmallSearchRangeShowsInTheCurve) {
  // Disparity 9 needs at least 10 disparities: at num_disp 8 nothing is right.
  testing::ScopedTempDir dir;
  testing::WriteSyntheticMiddlebury2001Scene(dir.path() / "middlebury-2001-2003" / "beta", 160, 48,
                                             9, 64, 2);
  const auto scenes = FindScenes(dir.path());
  SweepOptions options;
  options.parameters = {{"sgbm", kSweepNumDisparitiesKey, {"8", "32"}, "32"}};
  options.threads = 1;
  const SweepReport report = RunSweep(scenes, options);
  ASSERT_EQ(report.curves.size(), 1u);
  ASSERT_EQ(report.curves[0].points.size(), 2u);
  EXPECT_GT(report.curves[0].points[0].bad, 90.0);
  // At 32 only SGBM's empty left border (32 of 160 columns) remains.
  EXPECT_LT(report.curves[0].points[1].bad, 100.0 * 32 / 160 + 5);
  EXPECT_LT(report.curves[0].points[1].rmse, 1.5);
}

TEST(SweepTest, UnknownMethodOrKeyIsAUsageError) {
  testing::ScopedTempDir dir;
  const auto scenes = FindScenes(testing::WriteTwoSyntheticScenes(dir.path()));
  SweepOptions unknown_method;
  unknown_method.methods = {"nonexistent"};
  EXPECT_THROW(RunSweep(scenes, unknown_method), UsageError);
  SweepOptions unknown_key;
  unknown_key.parameters = {{"sgbm", "no_such_key", {"1"}, "1"}};
  EXPECT_THROW(RunSweep(scenes, unknown_key), UsageError);
}

}  // namespace
}  // namespace linesight
