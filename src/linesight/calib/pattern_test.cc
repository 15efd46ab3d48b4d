#include "linesight/calib/pattern.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "linesight/calib/target.h"
#include "linesight/core/error.h"

namespace linesight::calib {
namespace {

TEST(ParsePatternSpec, AcceptsEveryKind) {
  const PatternSpec chess = ParsePatternSpec("chessboard:9x6:0.025");
  EXPECT_EQ(chess.type, PatternType::kChessboard);
  EXPECT_EQ(chess.cols, 9);
  EXPECT_EQ(chess.rows, 6);
  EXPECT_DOUBLE_EQ(chess.square_m, 0.025);
  const PatternSpec charuco = ParsePatternSpec("charuco:7x5:0.04:0.03:5x5_100");
  EXPECT_EQ(charuco.type, PatternType::kCharuco);
  EXPECT_DOUBLE_EQ(charuco.marker_m, 0.03);
  EXPECT_EQ(charuco.dictionary, "5x5_100");
  EXPECT_EQ(ParsePatternSpec("circles:4x11:0.02").type, PatternType::kCircles);
  EXPECT_EQ(ParsePatternSpec("acircles:4x11:0.02").type, PatternType::kAsymmetricCircles);
}

TEST(ParsePatternSpec, RejectsBadSpecsWithAClearMessage) {
  for (const char* bad :
       {"", "chessboard", "chessboard:9x6", "chessboard:9*6:0.025", "chessboard:9x6:abc",
        "chessboard:9x6:-1", "chessboard:1x6:0.02", "chessboard:9x6:0.02:1", "hexagons:3x3:1",
        "charuco:7x5:0.04", "charuco:7x5:0.04:0.05", "charuco:7x5:0.04:0.03:9x9_1",
        "charuco:20x20:0.04:0.03:4x4_50"}) {
    try {
      ParsePatternSpec(bad);
      ADD_FAILURE() << "accepted '" << bad << "'";
    } catch (const UsageError& e) {
      EXPECT_NE(std::string(e.what()).find("expected chessboard:COLSxROWS:SQUARE_M"),
                std::string::npos)
          << e.what();
    }
  }
}

TEST(BoardGeometry, ChessboardAndAsymmetricCircles) {
  const BoardGeometry chess = MakeBoardGeometry(ParsePatternSpec("chessboard:4x3:0.5"));
  ASSERT_EQ(chess.points.size(), 12u);
  EXPECT_EQ(chess.points[5], Eigen::Vector3d(0.5, 0.5, 0));
  EXPECT_EQ(chess.adjacent.size(), 3u * 3 + 4u * 2);
  for (const AdjacentPair& p : chess.adjacent) EXPECT_DOUBLE_EQ(p.distance_m, 0.5);
  const BoardGeometry circles = MakeBoardGeometry(ParsePatternSpec("acircles:4x3:1"));
  EXPECT_EQ(circles.points[4], Eigen::Vector3d(1, 1, 0));  // row 1 is shifted by one spacing
  const BoardGeometry charuco = MakeBoardGeometry(ParsePatternSpec("charuco:5x4:0.1:0.07"));
  EXPECT_EQ(charuco.points.size(), 4u * 3);
}

// Renders each target, blurs it a little, and detects it: every corner at its exact position.
TEST(DetectPattern, FindsRenderedTargetsAtTheirExactPositions) {
  struct Case {
    PatternType type;
    int cols, rows;
    bool sector_based;
  };
  for (const Case& c :
       {Case{PatternType::kChessboard, 9, 6, true}, Case{PatternType::kChessboard, 9, 6, false},
        Case{PatternType::kCircles, 6, 5, true}, Case{PatternType::kAsymmetricCircles, 4, 7, true},
        Case{PatternType::kCharuco, 7, 5, true}}) {
    TargetOptions options;
    options.type = c.type;
    options.cols = c.cols;
    options.rows = c.rows;
    options.screen = {640, 480};
    options.pixel_pitch_m = 0.0003;
    const RenderedTarget target = RenderTarget(options);
    EXPECT_NEAR(target.square_m, target.square_px * 0.0003, 1e-15);
    const PatternSpec spec = ParsePatternSpec(target.pattern_spec);
    cv::Mat blurred;
    cv::GaussianBlur(target.image, blurred, cv::Size(5, 5), 1.0);
    DetectionOptions detection_options;
    detection_options.sector_based = c.sector_based;
    const Detection d = DetectPattern(blurred, spec, detection_options);
    ASSERT_TRUE(d.found) << target.pattern_spec << ": " << d.reason;
    const BoardGeometry board = MakeBoardGeometry(spec);
    ASSERT_GE(d.ids.size(), board.points.size() / 2);
    // Board axes may be reported in either direction: compare against both corner-0 placements.
    double error_forward = 0, error_reversed = 0;
    const double scale = target.square_px / spec.square_m;
    const Eigen::Vector2d far_corner = board.points.back().head<2>() * scale;
    for (size_t k = 0; k < d.ids.size(); ++k) {
      const Eigen::Vector2d expected = Eigen::Vector2d(target.origin_px.x, target.origin_px.y) +
                                       board.points[d.ids[k]].head<2>() * scale;
      const Eigen::Vector2d reversed = Eigen::Vector2d(target.origin_px.x, target.origin_px.y) +
                                       far_corner - board.points[d.ids[k]].head<2>() * scale;
      const Eigen::Vector2d found(d.pixels[k].x, d.pixels[k].y);
      error_forward = std::max(error_forward, (found - expected).norm());
      error_reversed = std::max(error_reversed, (found - reversed).norm());
    }
    EXPECT_LT(std::min(error_forward, error_reversed), 0.15) << target.pattern_spec;
  }
}

TEST(DetectPattern, ReportsWhyABoardWasRejected) {
  const cv::Mat blank(240, 320, CV_8UC1, cv::Scalar(128));
  const Detection d =
      DetectPattern(blank, ParsePatternSpec("chessboard:9x6:0.025"), DetectionOptions());
  EXPECT_FALSE(d.found);
  EXPECT_NE(d.reason.find("9x6"), std::string::npos);
  const Detection c =
      DetectPattern(blank, ParsePatternSpec("charuco:5x4:0.04:0.03"), DetectionOptions());
  EXPECT_FALSE(c.found);
  EXPECT_FALSE(c.reason.empty());
}

TEST(TargetOptions, DefaultsNeedOnlyThePitchAndBoundariesAreChecked) {
  TargetOptions o;
  EXPECT_THROW(o.Check(), OptionError);  // pitch unset
  o.pixel_pitch_m = 0.00025;
  EXPECT_NO_THROW(o.Check());
  o.square_px = 500;  // 10 squares of 500 px do not fit 1920 px
  EXPECT_THROW(RenderTarget(o), OptionError);
  o = {};
  o.pixel_pitch_m = 0.00025;
  o.marker_fraction = 1.0;
  EXPECT_THROW(o.Check(), OptionError);
  EXPECT_NO_THROW(DetectionOptions().Check());
  DetectionOptions d;
  d.subpixel_half_window = 0;
  EXPECT_THROW(d.Check(), OptionError);
}

}  // namespace
}  // namespace linesight::calib
