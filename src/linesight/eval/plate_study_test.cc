#include "linesight/eval/plate_study.h"

#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>

#include "linesight/core/error.h"
#include "linesight/eval/eval_test_util.h"
#include "linesight/ranging/ranging_settings.h"

namespace linesight {
namespace {

namespace fs = std::filesystem;

using test::kOpenCvData;

// The ranging accuracy on pairs from another renderer: a photograph-textured plate and box at known
// depths, ranged through the chain of `linesight range --rectified` with the wall inside the ROI.
TEST(PlateStudyTest, PhotographTexturedPlateAndBoxAreRangedWithinOnePercent) {
  if (!fs::exists(kOpenCvData / "baboon.jpg") || !fs::exists(kOpenCvData / "leuvenA.jpg")) {
    GTEST_SKIP() << "opencv-doc sample images not found at " << kOpenCvData
                 << " (scripts/install-deps.sh installs them)";
  }
  PlateStudyOptions options;
  options.shapes = {sim::PlateShape::kPlate, sim::PlateShape::kBox};
  options.textures = {"baboon.jpg"};
  options.distances = {1.0, 3.0};
  options.runs = 2;
  options.supersampling = 2;
  options.pipeline.method = "isgm";
  const PlateStudyReport report = RunPlateStudy(options);
  ASSERT_EQ(report.cells.size(), 4u);
  for (const PlateCell& c : report.cells) {
    SCOPED_TRACE(c.shape + " " + std::to_string(c.truth_m));
    EXPECT_EQ(c.measured, c.runs);
    EXPECT_LT(std::abs(c.relative_error()), 0.01);
    EXPECT_GT(c.mean_sigma_m, 0.0);
  }
  EXPECT_NE(report.ToMarkdown().find("| box | baboon |"), std::string::npos);
  EXPECT_EQ(report.ToJson()["cells"].size(), 4u);
  // Every setting of the chain is recorded; the study ranges rectified pairs.
  const nlohmann::json settings = report.ToJson()["ranging_settings"];
  EXPECT_EQ(settings.size(), RangingSettingsTable().rows().size());
  RangingPipelineOptions ran = options.pipeline;
  ran.input_rectified = true;
  EXPECT_EQ(settings, RangingSettingsTable().ToJson(ran));
}

TEST(PlateStudyTest, MissingTextureIsAnInputErrorNamingTheFile) {
  PlateStudyOptions options;
  options.texture_dir = "/nonexistent-folder";
  options.distances = {1.0};
  options.runs = 1;
  try {
    RunPlateStudy(options);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent-folder"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace linesight
