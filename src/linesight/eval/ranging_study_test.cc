#include "linesight/eval/ranging_study.h"

#include <unistd.h>

#include <cmath>
#include <filesystem>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "linesight/core/atomic_file.h"
#include "linesight/core/error.h"
#include "linesight/ranging/ranging_settings.h"

namespace linesight {
namespace {

namespace fs = std::filesystem;

// The smallest study: one damper at 1.5 m, one run, the true calibration, no Middlebury check.
RangingStudyOptions SmallStudy() {
  RangingStudyOptions o;
  o.runs = 1;
  o.types = {sim::ObstacleType::kDamper};
  o.distances = {1.5};
  o.calibrations = {StudyCalibration::kTrue};
  o.supersampling = 1;
  o.middlebury_dir.clear();
  return o;
}

TEST(RangingStudyOptions, DefaultsAreValidAndBoundsAreChecked) {
  EXPECT_NO_THROW(RangingStudyOptions().Check());
  RangingStudyOptions o;
  o.runs = 0;
  EXPECT_THROW(o.Check(), OptionError);
  o = {};
  o.distances = {};
  EXPECT_THROW(o.Check(), OptionError);
  o = {};
  o.distances = {1.0, -2.0};
  EXPECT_THROW(o.Check(), OptionError);
  o = {};
  o.types = {};
  EXPECT_THROW(o.Check(), OptionError);
  o = {};
  o.calibrations = {};
  EXPECT_THROW(o.Check(), OptionError);
  o = {};
  o.boards = 2;
  EXPECT_THROW(o.Check(), OptionError);
  o = {};
  o.pipeline.max_depth_m = 0.1;  // below min_depth_m
  EXPECT_THROW(o.Check(), OptionError);
}

TEST(StudyCalibration, NamesRoundTripAndOthersAreRejected) {
  for (StudyCalibration c : {StudyCalibration::kTrue, StudyCalibration::kEstimated}) {
    EXPECT_EQ(ParseStudyCalibration(StudyCalibrationName(c)), c);
  }
  EXPECT_THROW(ParseStudyCalibration("guessed"), UsageError);
}

TEST(RangingStudy, RangesTheRenderedDamperWithinOnePercent) {
  const RangingStudyReport report = RunRangingStudy(SmallStudy(), nullptr, nullptr);
  ASSERT_EQ(report.cells.size(), 1u);
  const RangingStudyCell& cell = report.cells.front();
  EXPECT_EQ(cell.calibration, "true");
  EXPECT_EQ(cell.type, "damper");
  EXPECT_EQ(cell.truth_m, 1.5);
  EXPECT_EQ(cell.runs, 1);
  EXPECT_EQ(cell.measured, 1);
  EXPECT_LT(std::abs(cell.relative_error()), 0.01);
  EXPECT_GT(cell.mean_sigma_m, 0.0);
  EXPECT_EQ(report.scenes, 1);
  EXPECT_FALSE(report.estimated_calibration);
  EXPECT_FALSE(report.middlebury);
  EXPECT_FALSE(report.method.empty());
  EXPECT_GT(report.disparity_range.num_disparities, 0);

  const nlohmann::json j = report.ToJson();
  EXPECT_EQ(j["runs"], 1);
  EXPECT_EQ(j["method"], report.method);
  ASSERT_EQ(j["cells"].size(), 1u);
  EXPECT_EQ(j["cells"][0]["true_distance_m"], 1.5);
  EXPECT_EQ(j["cells"][0]["measured"], 1);
  EXPECT_DOUBLE_EQ(j["cells"][0]["relative_error"].get<double>(), cell.relative_error());
  EXPECT_FALSE(j.contains("middlebury_motorcycle"));
  EXPECT_FALSE(j.contains("estimated_calibration"));
  EXPECT_EQ(report.MiddleburySummary(), "");
  // Every setting of the chain is recorded, with the value the study ran with.
  ASSERT_TRUE(j.contains("ranging_settings"));
  EXPECT_EQ(j["ranging_settings"].size(), RangingSettingsTable().rows().size());
  EXPECT_EQ(j["ranging_settings"], RangingSettingsTable().ToJson(SmallStudy().pipeline));
}

// The writers on a report with known numbers.
RangingStudyReport KnownReport() {
  RangingStudyReport r;
  r.method = "sgbm";
  r.disparity_range = {12, 287};  // min 12, 287 disparities: 12..298
  r.runs = 4;
  r.calibrations = {"true", "estimated"};
  r.types = {"damper"};
  for (const char* calibration : {"true", "estimated"}) {
    RangingStudyCell c;
    c.calibration = calibration;
    c.type = "damper";
    c.truth_m = 2.0;
    c.runs = 4;
    c.measured = 3;
    c.covered = 3;
    c.mean_m = 2.02;
    c.mean_abs_relative = 0.012;
    c.std_m = 0.005;
    c.mean_sigma_m = 0.02;
    c.failures["too few valid disparities"] = 1;
    r.cells.push_back(c);
  }
  r.estimated_calibration = StudyEstimatedCalibration{15, 14, 0.08, 0.12, 0.1, 740.0, 745.0};
  MiddleburyDepthCheck check;
  check.ran = true;
  check.median_relative_error = 0.0022;
  check.mean_relative_error = 0.0097;
  check.within_1_percent = 0.912;
  check.density = 1.0;
  check.pixels = 319078;
  r.middlebury = check;
  return r;
}

TEST(RangingStudyReport, MarkdownHasOneRowPerCell) {
  const std::string md = KnownReport().ToMarkdown();
  EXPECT_NE(md.find("| calibration | type | true m |"), std::string::npos) << md;
  EXPECT_NE(md.find("| true | damper | 2.00 | 4 | 3 | 2.0200 | +0.0200 | +1.00 | 1.20 | 0.0050 | "
                    "0.0200 | 100 |\n"),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("| estimated | damper | 2.00 |"), std::string::npos) << md;
  const std::string summary = KnownReport().MiddleburySummary();
  EXPECT_NE(summary.find("sgbm: depth Z"), std::string::npos) << summary;
  EXPECT_NE(summary.find("median relative error 0.22 %"), std::string::npos) << summary;
  EXPECT_NE(summary.find("91.2 % of 319078 pixels"), std::string::npos) << summary;
}

TEST(RangingStudyReport, JsonHoldsCellsCalibrationAndMiddlebury) {
  const nlohmann::json j = KnownReport().ToJson();
  EXPECT_EQ(j["disparity_range"], nlohmann::json({12, 298}));
  EXPECT_EQ(j["cells"].size(), 2u);
  EXPECT_NEAR(j["cells"][0]["relative_error"].get<double>(), 0.01, 1e-12);
  EXPECT_NEAR(j["cells"][0]["coverage_2sigma"].get<double>(), 1.0, 1e-12);
  EXPECT_EQ(j["cells"][0]["no_measurement_reasons"]["too few valid disparities"], 1);
  EXPECT_EQ(j["estimated_calibration"]["views_used"], 14);
  EXPECT_NEAR(j["estimated_calibration"]["baseline_relative_error"].get<double>(), 0.2, 1e-12);
  EXPECT_EQ(j["middlebury_motorcycle"]["pixels"], 319078);
  RangingStudyReport skipped = KnownReport();
  skipped.middlebury = MiddleburyDepthCheck{false, "calib.txt not found"};
  EXPECT_EQ(skipped.ToJson()["middlebury_motorcycle"]["skipped"], "calib.txt not found");
  EXPECT_EQ(skipped.MiddleburySummary(), "\nMiddlebury check skipped: calib.txt not found\n");
}

TEST(RangingStudyReport, SvgHasAPanelPerCalibrationAndAPointPerMeasuredCell) {
  RangingStudyReport r = KnownReport();
  const std::string svg = r.ToSvg();
  EXPECT_EQ(svg.rfind("<svg", 0), 0u);
  EXPECT_NE(svg.find("vs distance, true calibration"), std::string::npos);
  EXPECT_NE(svg.find("vs distance, estimated calibration"), std::string::npos);
  size_t circles = 0;
  for (size_t at = svg.find("<circle"); at != std::string::npos; at = svg.find("<circle", at + 1))
    ++circles;
  EXPECT_EQ(circles, 2u);
  r.cells[1].measured = 0;  // no point without a measurement
  const std::string fewer = r.ToSvg();
  EXPECT_EQ(fewer.find("<circle", fewer.find("<circle") + 1), std::string::npos);
}

TEST(MiddleburyDepthCheck, SkipsWithoutCalibAndRejectsOneWithoutNdisp) {
  const fs::path dir =
      fs::temp_directory_path() / fmt::format("linesight_ranging_study_{}", ::getpid());
  fs::create_directories(dir);
  const MiddleburyDepthCheck missing = CheckMiddleburyDepth(dir, RangingPipelineOptions());
  EXPECT_FALSE(missing.ran);
  EXPECT_NE(missing.reason.find("calib.txt not found"), std::string::npos) << missing.reason;
  WriteTextAtomic(dir / "calib.txt",
                  "cam0=[999 0 294; 0 999 252; 0 0 1]\ndoffs=32\nbaseline=193\n");
  EXPECT_THROW(CheckMiddleburyDepth(dir, RangingPipelineOptions()), InputError);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace linesight
