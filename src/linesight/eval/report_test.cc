#include "linesight/eval/report.h"

#include <gtest/gtest.h>

#include "linesight/core/atomic_file.h"
#include "linesight/core/error.h"
#include "linesight/eval/synthetic_scenes_test_util.h"

namespace linesight {
namespace {

// Options of a report over two tiny synthetic scenes written to dir/data, into dir/results.
ReportOptions TinyReportOptions(const testing::ScopedTempDir& dir) {
  testing::WriteTwoSyntheticScenes(dir.path() / "data");
  ReportOptions options;
  options.data_dir = dir.path() / "data";
  options.out_dir = dir.path() / "results";
  return options;
}

TEST(ReportTest, DefaultsValidAndBoundaries) {
  ReportOptions o;
  o.data_dir = "data";
  o.out_dir = "out";
  EXPECT_NO_THROW(o.Check());
  ReportOptions no_out = o;
  no_out.out_dir.clear();
  EXPECT_THROW(no_out.Check(), OptionError);
  ReportOptions noisy_first = o;
  noisy_first.noise = {NoiseSpec::Parse("gauss:0.1")};
  EXPECT_THROW(noisy_first.Check(), OptionError);
  ReportOptions quick = o;
  quick.MakeQuick();
  EXPECT_NO_THROW(quick.Check());
  EXPECT_EQ(quick.sweep_max_scenes, 2);
  // The full default covers the whole study: gc and the noise study on every set.
  EXPECT_EQ(o.gc_sets, std::vector<std::string>{"*"});
  EXPECT_TRUE(o.noise_sets.empty());
  EXPECT_EQ(o.noise.size(), 5u);
  ReportOptions negative_jobs = o;
  negative_jobs.gc_jobs = -1;
  EXPECT_THROW(negative_jobs.Check(), OptionError);
}

TEST(ReportTest, GitDescriptionNamesTheCommitOrSaysUnknown) {
  const std::string here = GitDescription(std::filesystem::path(__FILE__).parent_path());
  EXPECT_FALSE(here.empty());
  EXPECT_EQ(GitDescription("/nonexistent/folder"), "unknown");
}

TEST(ReportTest, MachineDescriptionNamesTheThreads) {
  EXPECT_NE(MachineDescription().find("hardware threads"), std::string::npos);
}

TEST(ReportTest, PageOnTinySyntheticDataHasEverySection) {
  testing::ScopedTempDir dir;
  ReportOptions options = TinyReportOptions(dir);
  options.methods = {"isgm", "sgbm", "gc"};
  options.gc_jobs = 2;  // gc runs side by side
  options.noise = {NoiseSpec(), NoiseSpec::Parse("sp:0.15")};
  options.sweep_methods = {"sgbm"};
  options.obstacles = false;  // rendering the power-line scene is covered by the sim tests
  options.threads = 1;
  options.command_line = "report_test";
  options.show_progress = false;
  const std::string page = GenerateReport(options);
  EXPECT_EQ(ReadTextFile(options.out_dir / "README.md"), page);
  for (const char* section :
       {"## 1. Comparison table", "## 2. Stereo benchmarks", "## 3. Noise robustness",
        "## 4. Parameter study", "## 5. Obstacle images", "## 6. Conclusion"}) {
    EXPECT_NE(page.find(section), std::string::npos) << section;
  }
  // Provenance with every figure, both scenes in the tables, computed conclusion lines.
  EXPECT_NE(page.find("produced by `report_test`"), std::string::npos);
  EXPECT_NE(page.find("hardware threads"), std::string::npos);
  EXPECT_NE(page.find("| alpha | isgm |"), std::string::npos);
  EXPECT_NE(page.find("| beta | sgbm |"), std::string::npos);
  EXPECT_NE(page.find("| beta | gc |"), std::string::npos);
  EXPECT_NE(page.find("| middlebury-2001-2003 | alpha | gc |"), std::string::npos);  // per scene
  EXPECT_NE(page.find("gc (graph cuts) ran on every set"), std::string::npos);
  EXPECT_NE(page.find("**isgm vs gc** — accuracy: isgm"), std::string::npos);
  EXPECT_NE(page.find("**isgm vs sgbm** — accuracy: isgm"), std::string::npos);
  EXPECT_NE(page.find("Noise (mean headline error over 2 scene(s)): isgm is better at"),
            std::string::npos);
  EXPECT_NE(page.find("Parameter study, sgbm block"), std::string::npos);
  for (const char* plot : {"noise.svg", "sweep_rmse.svg", "sweep_bad.svg"}) {
    EXPECT_TRUE(std::filesystem::exists(options.out_dir / plot)) << plot;
    EXPECT_NE(page.find(std::string("(") + plot + ")"), std::string::npos) << plot;
  }
}

TEST(ReportTest, MissingSetIsAnInputError) {
  testing::ScopedTempDir dir;
  ReportOptions options = TinyReportOptions(dir);
  options.sets = {"kitti-2015"};
  options.show_progress = false;
  EXPECT_THROW(GenerateReport(options), InputError);
  EXPECT_FALSE(std::filesystem::exists(options.out_dir));
}

TEST(ReportTest, BadSetOrMethodFailsBeforeAnythingIsWritten) {
  testing::ScopedTempDir dir;
  ReportOptions base = TinyReportOptions(dir);
  base.show_progress = false;
  ReportOptions gc = base;
  gc.gc_sets = {"middlebury-2001-2003", "no-such-set"};
  ReportOptions noise = base;
  noise.noise_sets = {"no-such-set"};
  ReportOptions sweep = base;
  sweep.sweep_sets = {"no-such-set"};
  for (const ReportOptions& o : {gc, noise, sweep}) {
    try {
      GenerateReport(o);
      ADD_FAILURE() << "no error";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("unknown set 'no-such-set'"), std::string::npos)
          << e.what();
    }
    EXPECT_FALSE(std::filesystem::exists(base.out_dir));
  }
  ReportOptions method = base;
  method.methods = {"isgm", "nonsense"};
  EXPECT_THROW(GenerateReport(method), UsageError);
  EXPECT_FALSE(std::filesystem::exists(base.out_dir));
}

}  // namespace
}  // namespace linesight
