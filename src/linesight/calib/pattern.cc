#include "linesight/calib/pattern.h"

#include <algorithm>
#include <charconv>
#include <limits>
#include <map>

#include <opencv2/aruco/charuco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "linesight/core/error.h"
#include "linesight/core/progress.h"
#include "linesight/io/image_io.h"

namespace linesight::calib {
namespace {

constexpr const char* kPatternGrammar =
    "expected chessboard:COLSxROWS:SQUARE_M, charuco:COLSxROWS:SQUARE_M:MARKER_M[:DICT], "
    "circles:COLSxROWS:SPACING_M or acircles:COLSxROWS:SPACING_M (e.g. chessboard:9x6:0.025)";

std::vector<std::string> Split(const std::string& text, char separator) {
  std::vector<std::string> parts;
  size_t start = 0;
  while (true) {
    const size_t end = text.find(separator, start);
    parts.push_back(text.substr(start, end - start));
    if (end == std::string::npos) break;
    start = end + 1;
  }
  return parts;
}

bool ParseInt(const std::string& text, int* value) {
  const auto result = std::from_chars(text.data(), text.data() + text.size(), *value);
  return result.ec == std::errc() && result.ptr == text.data() + text.size();
}

bool ParsePositiveDouble(const std::string& text, double* value) {
  if (text.empty()) return false;
  try {
    size_t used = 0;
    *value = std::stod(text, &used);
    return used == text.size() && std::isfinite(*value) && *value > 0;
  } catch (const std::exception&) {
    return false;
  }
}

const std::map<std::string, int>& DictionaryNames() {
  static const std::map<std::string, int> names = {
      {"4x4_50", cv::aruco::DICT_4X4_50},   {"4x4_100", cv::aruco::DICT_4X4_100},
      {"4x4_250", cv::aruco::DICT_4X4_250}, {"5x5_100", cv::aruco::DICT_5X5_100},
      {"5x5_250", cv::aruco::DICT_5X5_250}, {"6x6_250", cv::aruco::DICT_6X6_250},
      {"7x7_250", cv::aruco::DICT_7X7_250}};
  return names;
}

cv::Ptr<cv::aruco::CharucoBoard> MakeCharucoBoard(const PatternSpec& spec) {
  const auto dictionary = cv::aruco::getPredefinedDictionary(
      static_cast<cv::aruco::PREDEFINED_DICTIONARY_NAME>(DictionaryNames().at(spec.dictionary)));
  return cv::aruco::CharucoBoard::create(spec.cols, spec.rows, static_cast<float>(spec.square_m),
                                         static_cast<float>(spec.marker_m), dictionary);
}

}  // namespace

PatternSpec ParsePatternSpec(const std::string& text) {
  const auto fail = [&](const std::string& why) -> PatternSpec {
    throw UsageError(fmt::format("pattern '{}': {}; {}", text, why, kPatternGrammar));
  };
  const std::vector<std::string> parts = Split(text, ':');
  PatternSpec spec;
  spec.text = text;
  const std::string& kind = parts[0];
  size_t expected_min = 3, expected_max = 3;
  if (kind == "chessboard") {
    spec.type = PatternType::kChessboard;
  } else if (kind == "charuco") {
    spec.type = PatternType::kCharuco;
    expected_min = 4;
    expected_max = 5;
  } else if (kind == "circles") {
    spec.type = PatternType::kCircles;
  } else if (kind == "acircles") {
    spec.type = PatternType::kAsymmetricCircles;
  } else {
    return fail(fmt::format("unknown pattern type '{}'", kind));
  }
  if (parts.size() < expected_min || parts.size() > expected_max) {
    return fail(fmt::format("{} fields given", parts.size()));
  }
  const std::vector<std::string> grid = Split(parts[1], 'x');
  if (grid.size() != 2 || !ParseInt(grid[0], &spec.cols) || !ParseInt(grid[1], &spec.rows)) {
    return fail(fmt::format("grid '{}' is not COLSxROWS", parts[1]));
  }
  const int min_size = spec.type == PatternType::kCharuco ? 3 : 2;
  if (spec.cols < min_size || spec.rows < min_size) {
    return fail(fmt::format("grid {}x{} is too small (at least {}x{})", spec.cols, spec.rows,
                            min_size, min_size));
  }
  if (!ParsePositiveDouble(parts[2], &spec.square_m)) {
    return fail(fmt::format("size '{}' is not a positive number of metres", parts[2]));
  }
  if (spec.type == PatternType::kCharuco) {
    if (!ParsePositiveDouble(parts[3], &spec.marker_m) || spec.marker_m >= spec.square_m) {
      return fail(
          fmt::format("marker size '{}' must be positive and smaller than the square", parts[3]));
    }
    if (parts.size() == 5) {
      if (!DictionaryNames().count(parts[4]))
        return fail(fmt::format("unknown dictionary '{}'", parts[4]));
      spec.dictionary = parts[4];
    }
    const int markers = (spec.cols * spec.rows) / 2;
    const int capacity = std::stoi(spec.dictionary.substr(spec.dictionary.find('_') + 1));
    if (markers > capacity) {
      return fail(fmt::format("{} markers do not fit dictionary {}", markers, spec.dictionary));
    }
  }
  return spec;
}

int ArucoDictionaryId(const std::string& name) {
  const auto it = DictionaryNames().find(name);
  if (it == DictionaryNames().end())
    throw UsageError(fmt::format("unknown ArUco dictionary '{}'", name));
  return it->second;
}

BoardGeometry MakeBoardGeometry(const PatternSpec& spec) {
  BoardGeometry board;
  board.spacing_m = spec.square_m;
  int cols = spec.cols, rows = spec.rows;
  if (spec.type == PatternType::kCharuco) {
    cols = spec.cols - 1;
    rows = spec.rows - 1;
    const auto charuco = MakeCharucoBoard(spec);
    for (const cv::Point3f& p : charuco->chessboardCorners)
      board.points.emplace_back(p.x, p.y, p.z);
  } else {
    for (int r = 0; r < rows; ++r) {
      for (int c = 0; c < cols; ++c) {
        double x = c * spec.square_m;
        if (spec.type == PatternType::kAsymmetricCircles) x = (2 * c + r % 2) * spec.square_m;
        board.points.emplace_back(x, r * spec.square_m, 0.0);
      }
    }
  }
  LS_CHECK(static_cast<int>(board.points.size()) == cols * rows);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const int id = r * cols + c;
      const auto add = [&](int other) {
        board.adjacent.push_back({id, other, (board.points[id] - board.points[other]).norm()});
      };
      if (c + 1 < cols) add(id + 1);
      if (r + 1 < rows) add(id + cols);
    }
  }
  return board;
}

std::vector<Eigen::Vector2d> BoardBendCoordinates(const BoardGeometry& board) {
  LS_CHECK(!board.points.empty());
  Eigen::Vector2d low = board.points[0].head<2>(), high = low;
  for (const Eigen::Vector3d& p : board.points) {
    low = low.cwiseMin(p.head<2>());
    high = high.cwiseMax(p.head<2>());
  }
  const Eigen::Vector2d centre = 0.5 * (low + high);
  const Eigen::Vector2d half = (0.5 * (high - low)).cwiseMax(1e-12);
  std::vector<Eigen::Vector2d> uv;
  for (const Eigen::Vector3d& p : board.points)
    uv.push_back((p.head<2>() - centre).cwiseQuotient(half));
  return uv;
}

BoardGeometry BendBoard(const BoardGeometry& board, const BoardBend& bend) {
  BoardGeometry bent = board;
  const std::vector<Eigen::Vector2d> uv = BoardBendCoordinates(board);
  for (size_t i = 0; i < bent.points.size(); ++i) {
    const double u = uv[i].x(), v = uv[i].y();
    bent.points[i].z() += bend[0] * u * u + bend[1] * v * v + bend[2] * u * v;
  }
  return bent;
}

void DetectionOptions::Check() const {
  CheckOption(subpixel_half_window >= 1 && subpixel_half_window <= 50,
              "DetectionOptions.subpixel_half_window", subpixel_half_window, "must be in [1, 50]");
  CheckOption(min_charuco_corners >= 4, "DetectionOptions.min_charuco_corners", min_charuco_corners,
              "must be >= 4");
}

Detection DetectPattern(const cv::Mat& gray, const PatternSpec& spec,
                        const DetectionOptions& options) {
  options.Check();
  LS_CHECK(gray.type() == CV_8UC1);
  Detection detection;
  std::vector<cv::Point2f> corners;
  const cv::Size grid(spec.cols, spec.rows);
  const auto fill_all = [&]() {
    for (size_t i = 0; i < corners.size(); ++i) {
      detection.ids.push_back(static_cast<int>(i));
      detection.pixels.emplace_back(corners[i].x, corners[i].y);
    }
    detection.found = true;
  };
  const cv::TermCriteria subpix_criteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 50, 1e-3);
  const cv::Size subpix_window(options.subpixel_half_window, options.subpixel_half_window);
  switch (spec.type) {
    case PatternType::kChessboard: {
      bool found = false;
      if (options.sector_based) {
        found = cv::findChessboardCornersSB(gray, grid, corners,
                                            cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_ACCURACY);
      } else {
        found = cv::findChessboardCorners(
            gray, grid, corners, cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE);
      }
      if (!found) {
        detection.reason = fmt::format("no {}x{} chessboard found", spec.cols, spec.rows);
        return detection;
      }
      if (!options.sector_based || options.refine_sector_based) {
        // The window must not reach the neighbouring corners.
        double spacing = std::numeric_limits<double>::infinity();
        for (int r = 0; r < spec.rows; ++r) {
          for (int c = 0; c < spec.cols; ++c) {
            const cv::Point2f& p = corners[r * spec.cols + c];
            if (c + 1 < spec.cols)
              spacing = std::min(spacing, cv::norm(corners[r * spec.cols + c + 1] - p));
            if (r + 1 < spec.rows)
              spacing = std::min(spacing, cv::norm(corners[(r + 1) * spec.cols + c] - p));
          }
        }
        const int half = std::max(
            2, std::min(options.subpixel_half_window, static_cast<int>(std::floor(0.4 * spacing))));
        cv::cornerSubPix(gray, corners, cv::Size(half, half), cv::Size(-1, -1), subpix_criteria);
      }
      fill_all();
      return detection;
    }
    case PatternType::kCircles:
    case PatternType::kAsymmetricCircles: {
      const int flags = spec.type == PatternType::kCircles ? cv::CALIB_CB_SYMMETRIC_GRID
                                                           : cv::CALIB_CB_ASYMMETRIC_GRID;
      if (!cv::findCirclesGrid(gray, grid, corners, flags)) {
        detection.reason =
            fmt::format("no {}x{} {} circle grid found", spec.cols, spec.rows,
                        spec.type == PatternType::kCircles ? "symmetric" : "asymmetric");
        return detection;
      }
      fill_all();
      return detection;
    }
    case PatternType::kCharuco: {
      const auto board = MakeCharucoBoard(spec);
      std::vector<int> marker_ids;
      std::vector<std::vector<cv::Point2f>> marker_corners;
      cv::aruco::detectMarkers(gray, board->dictionary, marker_corners, marker_ids);
      if (marker_ids.empty()) {
        detection.reason = "no ArUco markers of dictionary " + spec.dictionary + " found";
        return detection;
      }
      std::vector<int> ids;
      cv::aruco::interpolateCornersCharuco(marker_corners, marker_ids, gray, board, corners, ids);
      if (static_cast<int>(ids.size()) < options.min_charuco_corners) {
        detection.reason = fmt::format("only {} ChArUco corners found (need {})", ids.size(),
                                       options.min_charuco_corners);
        return detection;
      }
      // Refine with the same sub-pixel step as the classic chessboard detector: OpenCV 4.6's
      // interpolated ChArUco corners sit +0.5 px off in x and y on a rendered board (pixel-corner
      // convention); after this step they match the chessboard detectors (pixel-centre convention),
      // see pattern_test.cc.
      cv::cornerSubPix(gray, corners, subpix_window, cv::Size(-1, -1), subpix_criteria);
      detection.ids = ids;
      for (const cv::Point2f& p : corners) detection.pixels.emplace_back(p.x, p.y);
      detection.found = true;
      return detection;
    }
  }
  return detection;
}

int StereoDetections::LeftCount() const {
  return static_cast<int>(
      std::count_if(pairs.begin(), pairs.end(), [](auto& p) { return p.left.found; }));
}
int StereoDetections::RightCount() const {
  return static_cast<int>(
      std::count_if(pairs.begin(), pairs.end(), [](auto& p) { return p.right.found; }));
}
int StereoDetections::BothCount() const {
  return static_cast<int>(std::count_if(pairs.begin(), pairs.end(),
                                        [](auto& p) { return p.left.found && p.right.found; }));
}

namespace {

// One pair's detections into `out`, after the size checks of DetectStereoPairs; `left_name` and
// `right_name` name the images in errors.
void DetectPair(const cv::Mat& left, const std::string& left_name, const cv::Mat& right,
                const std::string& right_name, const std::string& first_name,
                const PatternSpec& spec, const DetectionOptions& options, StereoDetections* out) {
  CheckSameSize(left, left_name, right, right_name);
  if (out->pairs.empty()) {
    out->image_size = left.size();
  } else if (left.size() != out->image_size) {
    throw InputError(fmt::format("{} is {}x{} but {} is {}x{}; all images must have one size",
                                 left_name, left.cols, left.rows, first_name, out->image_size.width,
                                 out->image_size.height));
  }
  PairDetection pair;
  pair.left = DetectPattern(left, spec, options);
  pair.right = DetectPattern(right, spec, options);
  out->pairs.push_back(std::move(pair));
}

void CheckPairCounts(size_t left, size_t right) {
  if (left != right) {
    throw InputError(
        fmt::format("{} left images but {} right images; they must pair up", left, right));
  }
}

}  // namespace

StereoDetections DetectStereoImages(const std::vector<cv::Mat>& left_gray,
                                    const std::vector<cv::Mat>& right_gray, const PatternSpec& spec,
                                    const DetectionOptions& options) {
  options.Check();
  CheckPairCounts(left_gray.size(), right_gray.size());
  StereoDetections out;
  for (size_t i = 0; i < left_gray.size(); ++i) {
    DetectPair(left_gray[i], fmt::format("left image {}", i), right_gray[i],
               fmt::format("right image {}", i), "left image 0", spec, options, &out);
  }
  return out;
}

StereoDetections DetectStereoPairs(const std::vector<std::filesystem::path>& left_paths,
                                   const std::vector<std::filesystem::path>& right_paths,
                                   const PatternSpec& spec, const DetectionOptions& options,
                                   bool show_progress) {
  options.Check();
  CheckPairCounts(left_paths.size(), right_paths.size());
  StereoDetections out;
  ProgressBar progress(static_cast<int64_t>(left_paths.size()), "detecting",
                       show_progress && StderrIsTerminal());
  for (size_t i = 0; i < left_paths.size(); ++i) {
    const cv::Mat left = ReadImage(left_paths[i], ImageColor::kGray);
    const cv::Mat right = ReadImage(right_paths[i], ImageColor::kGray);
    DetectPair(left, left_paths[i].string(), right, right_paths[i].string(), left_paths[0].string(),
               spec, options, &out);
    out.pairs.back().left_path = left_paths[i];
    out.pairs.back().right_path = right_paths[i];
    progress.Advance(1, left_paths[i].filename().string());
  }
  progress.Finish();
  return out;
}

}  // namespace linesight::calib
