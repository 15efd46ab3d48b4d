#include "linesight/stereo/throughput_bench.h"

#include <algorithm>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "linesight/core/error.h"

namespace linesight {
namespace {

TEST(ThroughputBench, InterleavedRoundsPoolTheirRuns) {
  BenchOptions options;
  options.sizes = {{96, 64, 21}};
  options.methods = {"sgm", "sgbm-3way", "no-such-method"};
  options.runs = 2;
  options.warmup = 0;
  options.rounds = 3;
  options.threads = 1;
  std::vector<std::string> reported;
  const BenchReport report =
      RunThroughputBench(options, [&](const BenchRow& row) { reported.push_back(row.method); });
  ASSERT_EQ(report.rows.size(), 3u);
  EXPECT_EQ(reported, (std::vector<std::string>{"sgm", "sgbm-3way", "no-such-method"}));
  EXPECT_EQ(report.rounds, 3);
  for (int m = 0; m < 2; ++m) {
    const BenchRow& row = report.rows[m];
    ASSERT_FALSE(row.skipped) << row.method << ": " << row.note;
    EXPECT_EQ(row.round_median_ms.size(), 3u) << row.method;
    EXPECT_GT(row.median_ms, 0) << row.method;
    EXPECT_LE(row.min_ms, row.median_ms) << row.method;
    EXPECT_NEAR(row.mde_per_s, 96.0 * 64 * 21 / row.median_ms / 1000.0, 1e-9) << row.method;
    EXPECT_GT(row.peak_rss_mb, 0) << row.method;
    EXPECT_GT(row.density, 0) << row.method;
  }
  const BenchRow& sgm = report.rows[0];
  const BenchRow& base = report.rows[1];
  EXPECT_DOUBLE_EQ(base.ratio_to_3way, 1.0);
  EXPECT_DOUBLE_EQ(sgm.ratio_to_3way, base.median_ms / sgm.median_ms);
  EXPECT_LE(sgm.ratio_low, sgm.ratio_high);
  EXPECT_GT(sgm.ratio_low, 0);
  // Paired: the median of the three per-round ratios, i.e. one of them.
  std::vector<double> ratios;
  for (int r = 0; r < 3; ++r) ratios.push_back(base.round_median_ms[r] / sgm.round_median_ms[r]);
  std::sort(ratios.begin(), ratios.end());
  EXPECT_DOUBLE_EQ(sgm.ratio_paired, ratios[1]);
  EXPECT_DOUBLE_EQ(base.ratio_paired, 1.0);
  EXPECT_TRUE(report.rows[2].skipped);
  EXPECT_NE(report.rows[2].note.find("not registered"), std::string::npos);
  const std::string table = BenchMarkdown(report);
  EXPECT_NE(table.find("3 rounds x 2 runs"), std::string::npos) << table;
  EXPECT_NE(BenchJson(report)["rows"][0]["round_median_ms"].size(), 0u);
}

TEST(ThroughputBench, RejectsZeroRounds) {
  BenchOptions options;
  options.rounds = 0;
  EXPECT_THROW(options.Check(), OptionError);
}

TEST(ThroughputBench, MethodSettingsFollowTheName) {
  std::string method;
  std::map<std::string, std::string> params;
  SplitBenchMethod("isgm:paths=8:p1=10", &method, &params);
  EXPECT_EQ(method, "isgm");
  EXPECT_EQ(params, (std::map<std::string, std::string>{{"paths", "8"}, {"p1", "10"}}));
  params.clear();
  SplitBenchMethod("sgbm-3way", &method, &params);
  EXPECT_EQ(method, "sgbm-3way");
  EXPECT_TRUE(params.empty());
  EXPECT_THROW(SplitBenchMethod("isgm:paths", &method, &params), UsageError);
  EXPECT_THROW(SplitBenchMethod("isgm:=4", &method, &params), UsageError);
  EXPECT_THROW(SplitBenchMethod(":paths=4", &method, &params), UsageError);
  params.clear();
  EXPECT_THROW(SplitBenchMethod("isgm:paths=4:paths=8", &method, &params), UsageError);
}

TEST(ThroughputBench, MeasuresTwoSettingsOfOneMethodApart) {
  BenchOptions options;
  options.sizes = {{96, 64, 21}};
  options.methods = {"sgm:paths=4", "sgm:paths=8"};
  options.runs = 1;
  options.warmup = 0;
  options.rounds = 1;
  options.threads = 1;
  const BenchReport report = RunThroughputBench(options, [](const BenchRow&) {});
  ASSERT_EQ(report.rows.size(), 2u);
  for (const BenchRow& row : report.rows) EXPECT_FALSE(row.skipped) << row.method << row.note;
  EXPECT_EQ(report.rows[0].method, "sgm:paths=4");
  // A setting the method does not have stops the run before any child is forked.
  options.methods = {"sgm:no_such_key=1"};
  EXPECT_THROW(RunThroughputBench(options, [](const BenchRow&) {}), UsageError);
  options.methods = {"sgm:paths=5"};
  EXPECT_THROW(RunThroughputBench(options, [](const BenchRow&) {}), UsageError);
  options.methods = {"sgbm-3way:mode=hh"};  // the name sets the mode
  EXPECT_THROW(RunThroughputBench(options, [](const BenchRow&) {}), UsageError);
}

}  // namespace
}  // namespace linesight
