#include "linesight/sim/board_calibration.h"

#include <unistd.h>

#include <filesystem>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "linesight/core/error.h"

namespace linesight::sim {
namespace {

CalibrationBoardOptions SmallBoardSet() {
  CalibrationBoardOptions o;
  o.num_stereo_views = 6;
  o.sensor.supersampling = 2;
  o.seed = 3;
  return o;
}

// Rendered and calibrated once for the tests below.
const BoardCalibration& SmallBoardCalibration() {
  static const BoardCalibration c =
      CalibrateFromRenderedBoards(SmallBoardSet(), calib::CalibrationMethod::kZhang);
  return c;
}

TEST(CalibrateFromRenderedBoards, EstimatesTheTrueRig) {
  const BoardCalibration& c = SmallBoardCalibration();
  ASSERT_EQ(c.boards.views.size(), 6u);
  EXPECT_EQ(c.detections.BothCount(), 6);
  EXPECT_LT(c.report.stereo_rms_px, 0.2);
  const double true_baseline = c.boards.calibration.Baseline();
  EXPECT_NEAR(c.report.calibration.Baseline(), true_baseline, 0.01 * true_baseline);
  EXPECT_NEAR(c.report.calibration.M1.at<double>(0, 0), c.boards.calibration.M1.at<double>(0, 0),
              0.01 * c.boards.calibration.M1.at<double>(0, 0));
  EXPECT_FALSE(c.report.calibration.P1.empty());  // rectified
}

// In memory the views are detected exactly as `linesight calibrate` detects them in the written
// PNG files (the same grey conversion), so both give the same corners.
TEST(CalibrateFromRenderedBoards, DetectsWhatTheWrittenBoardsShow) {
  const BoardCalibration& c = SmallBoardCalibration();
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    fmt::format("linesight_board_calibration_{}", ::getpid());
  WriteCalibrationBoards(dir, c.boards);
  std::vector<std::filesystem::path> left, right;
  for (size_t i = 0; i < c.boards.views.size(); ++i) {
    left.push_back(dir / fmt::format("left_{:02d}.png", i));
    right.push_back(dir / fmt::format("right_{:02d}.png", i));
  }
  const calib::PatternSpec spec = calib::ParsePatternSpec(fmt::format(
      "chessboard:{}x{}:{}", c.boards.board.cols, c.boards.board.rows, c.boards.board.square_m));
  const calib::StereoDetections from_files =
      calib::DetectStereoPairs(left, right, spec, calib::DetectionOptions(), false);
  std::filesystem::remove_all(dir);
  ASSERT_EQ(from_files.pairs.size(), c.detections.pairs.size());
  for (size_t i = 0; i < from_files.pairs.size(); ++i) {
    EXPECT_EQ(from_files.pairs[i].left.pixels, c.detections.pairs[i].left.pixels) << i;
    EXPECT_EQ(from_files.pairs[i].right.pixels, c.detections.pairs[i].right.pixels) << i;
  }
}

TEST(CalibrateFromRenderedBoards, TooFewDetectedViewsAreAnInputError) {
  CalibrationBoardOptions o = SmallBoardSet();
  o.num_stereo_views = 2;
  EXPECT_THROW(CalibrateFromRenderedBoards(o, calib::CalibrationMethod::kZhang), InputError);
}

}  // namespace
}  // namespace linesight::sim
