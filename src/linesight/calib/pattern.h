// Calibration patterns: the spec parser, the board geometry and the detectors.
//
// Pattern specs (metres; COLSxROWS as noted):
//   chessboard:COLSxROWS:SQUARE_M               inner corners, e.g. chessboard:9x6:0.025
//   charuco:COLSxROWS:SQUARE_M:MARKER_M[:DICT]  squares (not corners), DICT one of 4x4_50
//   (default),
//                                               4x4_100, 4x4_250, 5x5_100, 5x5_250, 6x6_250,
//                                               7x7_250
//   circles:COLSxROWS:SPACING_M                 symmetric circle grid, centre spacing
//   acircles:COLSxROWS:SPACING_M                asymmetric circle grid as OpenCV defines it: point
//   (i, j) of
//                                               row i and column j is at ((2j + i mod 2)·s, i·s)
#pragma once

#include <array>
#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace linesight::calib {

enum class PatternType { kChessboard, kCharuco, kCircles, kAsymmetricCircles };

struct PatternSpec {
  PatternType type = PatternType::kChessboard;
  int cols = 0;         // inner corners / circles per row; squares per row for ChArUco
  int rows = 0;         // inner corners / circles per column; squares per column for ChArUco
  double square_m = 0;  // square size or circle spacing (m)
  double marker_m = 0;  // ChArUco marker side (m)
  std::string dictionary = "4x4_50";  // ChArUco ArUco dictionary
  std::string text;                   // the spec as given

  // Smallest distance between neighbouring board points (m).
  double Spacing() const { return square_m; }
};

// Parses a pattern spec; throws UsageError naming the spec and the expected grammar.
PatternSpec ParsePatternSpec(const std::string& spec);

// The known board: point `id` at `points[id]` on the z = 0 plane (m), and the pairs of
// grid-adjacent points (for the reconstruction error), each with its true distance.
struct AdjacentPair {
  int a = 0;
  int b = 0;
  double distance_m = 0;
};
struct BoardGeometry {
  std::vector<Eigen::Vector3d> points;
  std::vector<AdjacentPair> adjacent;
  double spacing_m = 0;
};
BoardGeometry MakeBoardGeometry(const PatternSpec& spec);

// A shared out-of-plane bend of the board (recon's board-shape model, stereo_calibrator.h): point
// `id` moves along the board normal by b0·u² + b1·v² + b2·u·v (m), (u, v) =
// BoardBendCoordinates(board)[id] its board coordinates scaled to [−1, 1] over the point grid.
constexpr int kBoardBendSize = 3;
using BoardBend = std::array<double, kBoardBendSize>;
std::vector<Eigen::Vector2d> BoardBendCoordinates(const BoardGeometry& board);
// The board with its points bent (the adjacent pairs keep their nominal distances).
BoardGeometry BendBoard(const BoardGeometry& board, const BoardBend& bend);

// cv::aruco predefined dictionary id of a dictionary name ("4x4_50", ...); throws UsageError.
int ArucoDictionaryId(const std::string& name);

struct DetectionOptions {
  // Chessboards: true = cv::findChessboardCornersSB (sector-based, robust detection); false =
  // cv::findChessboardCorners + cv::cornerSubPix.
  bool sector_based = true;
  // Re-locate the sector-based detector's corners with cv::cornerSubPix. OpenCV 4.6's SB
  // localisation (CALIB_CB_ACCURACY) drifts toward the larger neighbouring squares of a board seen
  // in perspective (0.015-0.023 px on the rendered boards of sim/, 5 seeds; cornerSubPix: below
  // 0.003 px), which flattens the foreshortening: fx +0.15..+0.27 % on 3 of 5 rendered board
  // sets (cornerSubPix: −0.12..+0.08 %, mean +0.01 %). On opencv-doc's real pairs the stereo RMS
  // drops from 0.271 to 0.215 px.
  bool refine_sector_based = true;
  // Half window of cv::cornerSubPix for chessboards and ChArUco corners (px); for chessboards it
  // is reduced to 0.4x the smallest spacing of adjacent corners when the squares are small.
  int subpixel_half_window = 5;
  // ChArUco: fewest interpolated corners for a view to be used.
  int min_charuco_corners = 6;

  void Check() const;
};

// The board as seen in one image: ids index BoardGeometry::points.
struct Detection {
  bool found = false;
  std::string reason;  // why it was rejected (empty when found)
  std::vector<int> ids;
  std::vector<cv::Point2d> pixels;
};

// Detects the pattern in an 8-bit grey image.
Detection DetectPattern(const cv::Mat& gray, const PatternSpec& spec,
                        const DetectionOptions& options);

// One stereo pair's detections.
struct PairDetection {
  std::filesystem::path left_path, right_path;
  Detection left, right;
};
struct StereoDetections {
  cv::Size image_size;
  std::vector<PairDetection> pairs;
  int LeftCount() const;
  int RightCount() const;
  int BothCount() const;
};

// Detects every pair of 8-bit grey images (already in memory; the pairs' paths stay empty).
// Throws InputError when the counts differ or the sizes differ between left and right or across
// pairs.
StereoDetections DetectStereoImages(const std::vector<cv::Mat>& left_gray,
                                    const std::vector<cv::Mat>& right_gray, const PatternSpec& spec,
                                    const DetectionOptions& options);

// Reads and detects every pair (progress bar on stderr). Throws InputError when the counts differ,
// an image cannot be read, or the sizes differ between left and right or across pairs.
StereoDetections DetectStereoPairs(const std::vector<std::filesystem::path>& left_paths,
                                   const std::vector<std::filesystem::path>& right_paths,
                                   const PatternSpec& spec, const DetectionOptions& options,
                                   bool show_progress = true);

}  // namespace linesight::calib
