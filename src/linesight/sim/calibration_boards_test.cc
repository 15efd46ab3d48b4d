#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "linesight/core/error.h"
#include "linesight/sim/power_line_scene.h"

namespace linesight::sim {
namespace {

TEST(CalibrationBoardOptions, DefaultsAreValid) {
  EXPECT_NO_THROW(CalibrationBoardOptions().Check());
  EXPECT_NO_THROW(ChessboardOptions().Check());
}

TEST(CalibrationBoardOptions, RejectsBadValues) {
  CalibrationBoardOptions o;
  o.board.cols = 1;
  EXPECT_THROW(o.Check(), OptionError);
  o = {};
  o.board.border_squares = 0.2;
  EXPECT_THROW(o.Check(), OptionError);
  o = {};
  o.num_stereo_views = 0;
  EXPECT_THROW(o.Check(), OptionError);
  o = {};
  o.max_distance_m = 0.3;  // below min_distance_m
  EXPECT_THROW(o.Check(), OptionError);
  o = {};
  o.max_tilt_deg = 80;
  EXPECT_THROW(o.Check(), OptionError);
}

TEST(ChessboardOptions, ObjectPointsAreRowMajor) {
  ChessboardOptions b;
  const auto points = b.ObjectPoints();
  ASSERT_EQ(points.size(), 54u);
  EXPECT_FLOAT_EQ(points[1].x, 0.04f);
  EXPECT_FLOAT_EQ(points[9].y, 0.04f);
  EXPECT_FLOAT_EQ(points[53].x, 0.32f);
  EXPECT_FLOAT_EQ(points[53].y, 0.20f);
}

// Mean distance from each detected corner to the nearest true corner (the detector's ordering may
// start from another corner of the symmetric pattern).
double MeanCornerError(const std::vector<cv::Point2f>& detected,
                       const std::vector<cv::Point2d>& truth) {
  double sum = 0;
  for (const cv::Point2f& d : detected) {
    double best = 1e9;
    for (const cv::Point2d& t : truth) best = std::min(best, std::hypot(d.x - t.x, d.y - t.y));
    sum += best;
  }
  return sum / detected.size();
}

TEST(RenderCalibrationBoards, CornersAreDetectedWhereTheyProject) {
  CalibrationBoardOptions o;
  o.num_stereo_views = 3;
  o.num_left_only = 1;
  o.sensor.noise_sigma_dn = 0;
  const CalibrationBoardSet set = RenderCalibrationBoards(o);
  ASSERT_EQ(set.views.size(), 4u);
  const cv::Size pattern(o.board.cols, o.board.rows);
  for (size_t i = 0; i < set.views.size(); ++i) {
    const BoardView& view = set.views[i];
    SCOPED_TRACE(i);
    EXPECT_TRUE(view.board_in_left);
    EXPECT_EQ(view.board_in_right, i < 3);
    for (int camera = 0; camera < 2; ++camera) {
      const bool expected = camera == 0 ? view.board_in_left : view.board_in_right;
      if (!expected) continue;
      cv::Mat gray;
      cv::cvtColor(camera == 0 ? view.left : view.right, gray, cv::COLOR_BGR2GRAY);
      std::vector<cv::Point2f> corners;
      ASSERT_TRUE(cv::findChessboardCornersSB(
          gray, pattern, corners, cv::CALIB_CB_ACCURACY | cv::CALIB_CB_NORMALIZE_IMAGE));
      ASSERT_EQ(corners.size(), 54u);
      const double error =
          MeanCornerError(corners, camera == 0 ? view.corners_left : view.corners_right);
      EXPECT_LT(error, 0.2) << "camera " << camera;
    }
  }
}

TEST(RenderCalibrationBoards, TruePoseProjectsTheCorners) {
  CalibrationBoardOptions o;
  o.num_stereo_views = 2;
  o.sensor.supersampling = 1;
  const CalibrationBoardSet set = RenderCalibrationBoards(o);
  const auto object = o.board.ObjectPoints();
  for (const BoardView& view : set.views) {
    cv::Vec3d rvec;
    cv::Rodrigues(cv::Mat(view.left_from_board_R), rvec);
    std::vector<cv::Point2f> projected;
    cv::projectPoints(object, rvec, view.left_from_board_t, set.calibration.M1, set.calibration.D1,
                      projected);
    for (size_t k = 0; k < object.size(); ++k) {
      EXPECT_NEAR(projected[k].x, view.corners_left[k].x, 1e-3);
      EXPECT_NEAR(projected[k].y, view.corners_left[k].y, 1e-3);
    }
  }
}

TEST(RenderCalibrationBoards, DeterministicInTheSeed) {
  CalibrationBoardOptions o;
  o.num_stereo_views = 1;
  o.sensor.supersampling = 1;
  const CalibrationBoardSet a = RenderCalibrationBoards(o);
  const CalibrationBoardSet b = RenderCalibrationBoards(o);
  EXPECT_EQ(cv::norm(a.views[0].left, b.views[0].left, cv::NORM_INF), 0.0);
  o.seed = 2;
  const CalibrationBoardSet c = RenderCalibrationBoards(o);
  EXPECT_GT(cv::norm(a.views[0].left_from_board_t - c.views[0].left_from_board_t), 1e-3);
}

}  // namespace
}  // namespace linesight::sim
