#include "linesight/eval/real_ranging.h"

#include <cstdio>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "linesight/core/error.h"
#include "linesight/eval/eval_test_util.h"

namespace linesight {
namespace {

using test::kInf;
using test::kSharedData;

// A wall at disparity 20 with a box at disparity 40 in front of it (unknown truth in a strip).
StereoScene WallAndBox() {
  StereoScene s;
  s.ref.set = "synthetic";
  s.ref.name = "wall-and-box";
  s.ground_truth = cv::Mat(200, 300, CV_32F, cv::Scalar(20.0f));
  s.ground_truth(cv::Rect(60, 50, 80, 70)).setTo(40.0f);
  s.ground_truth(cv::Rect(0, 190, 300, 10)).setTo(kInf);
  s.masks["all"] = s.ground_truth != kInf;
  s.masks["nonocc"] = s.masks["all"].clone();
  s.focal_px = 500.0;
  s.baseline_m = 0.1;
  s.doffs_px = 10.0;
  return s;
}

TEST(DeriveRealRegions, FindsTheObjectInFrontAndPatchesOfEachSurface) {
  const std::vector<RealRegion> regions = DeriveRealRegions(WallAndBox(), RealRegionOptions());
  std::vector<RealRegion> objects, surfaces;
  for (const RealRegion& r : regions) (r.kind == "object" ? objects : surfaces).push_back(r);
  // The wall has the box in front of it: only the box is an object.
  ASSERT_EQ(objects.size(), 1u);
  EXPECT_EQ(objects[0].pixels, 80 * 70);
  EXPECT_TRUE((objects[0].roi & cv::Rect(60, 50, 80, 70)) == cv::Rect(60, 50, 80, 70));
  EXPECT_DOUBLE_EQ(objects[0].truth_disparity_px, 40.0);
  EXPECT_DOUBLE_EQ(objects[0].truth_m, 500.0 * 0.1 / (40.0 + 10.0));
  // One patch on the wall, one on the box, each inside its surface.
  ASSERT_EQ(surfaces.size(), 2u);
  for (const RealRegion& r : surfaces) {
    EXPECT_EQ(r.roi.width, 61);
    EXPECT_EQ(r.roi.height, 61);
  }
  const bool wall_first = surfaces[0].truth_disparity_px == 20.0;
  const RealRegion& wall = surfaces[wall_first ? 0 : 1];
  const RealRegion& box = surfaces[wall_first ? 1 : 0];
  EXPECT_DOUBLE_EQ(wall.truth_disparity_px, 20.0);
  EXPECT_DOUBLE_EQ(box.truth_disparity_px, 40.0);
  EXPECT_TRUE((box.roi & cv::Rect(60, 50, 80, 70)) == box.roi);
  EXPECT_TRUE((wall.roi & cv::Rect(60, 50, 80, 70)).empty());
}

TEST(DeriveRealRegions, TruthIsTheNearestPointOfASlantedSurface) {
  StereoScene s = WallAndBox();
  for (int y = 50; y < 120; ++y) {
    for (int x = 60; x < 140; ++x) s.ground_truth.at<float>(y, x) = 30.0f + 0.1f * float(x - 60);
  }
  RealRegionOptions options;
  options.max_surfaces = 0;
  const std::vector<RealRegion> regions = DeriveRealRegions(s, options);
  ASSERT_EQ(regions.size(), 1u);
  // The largest disparity is 37.9 at x = 139; the 5x5 mean there (3 columns inside) is 37.8.
  EXPECT_NEAR(regions[0].truth_disparity_px, 37.8, 1e-4);
}

TEST(DeriveRealRegions, RefusesASceneWithoutMetricCalibration) {
  StereoScene s = WallAndBox();
  s.focal_px = 0.0;
  try {
    DeriveRealRegions(s, RealRegionOptions());
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("synthetic/wall-and-box"), std::string::npos);
  }
}

TEST(RealRangingStudy, RangesTheRealPairsOfTheSharedData) {
  if (!std::filesystem::exists(kSharedData / "middlebury-2014-quarter")) {
    GTEST_SKIP() << "benchmark data not found at " << kSharedData << " (optional)";
  }
  RealRangingOptions options;
  options.root = kSharedData;
  options.pipeline.threads = 2;
  options.diagnose = true;
  std::FILE* log = std::tmpfile();
  ASSERT_NE(log, nullptr);
  const RealRangingReport report = RunRealRangingStudy(options, nullptr, log);
  EXPECT_EQ(report.scenes.size(), 12u);  // Motorcycle, terrace, ten 2005/2006 scenes
  // One diagnosis line per region, with the estimator's reading on the ground truth.
  std::rewind(log);
  std::string text;
  for (int c = std::fgetc(log); c != EOF; c = std::fgetc(log)) text.push_back(char(c));
  std::fclose(log);
  size_t lines = 0;
  for (size_t at = text.find("the estimator on the truth"); at != std::string::npos;
       at = text.find("the estimator on the truth", at + 1)) {
    ++lines;
  }
  EXPECT_EQ(lines, report.regions.size());
  const RealRangingReport::Summary all = report.Summarise();
  EXPECT_GE(all.regions, 50);
  EXPECT_GE(all.measured, all.regions - 2);
  // Single surfaces of the Middlebury scenes (structured-light truth): matching noise only.
  for (const char* set : {"middlebury-2005-2006-half", "middlebury-2014-quarter"}) {
    const RealRangingReport::Summary s = report.Summarise("surface", set);
    EXPECT_GE(s.measured, 4) << set;
    EXPECT_LE(s.median_abs, 0.003) << set;
  }
  std::printf("%s", report.ToMarkdown().c_str());
}

}  // namespace
}  // namespace linesight
