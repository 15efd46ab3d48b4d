#include "linesight/calib/target.h"

#include <opencv2/aruco/charuco.hpp>
#include <opencv2/imgproc.hpp>

#include "linesight/core/error.h"

namespace linesight::calib {
namespace {

// Pattern extent in squares (chessboard/charuco) or spacings plus one (circle grids).
cv::Size2d ExtentInSquares(const TargetOptions& o) {
  switch (o.type) {
    case PatternType::kChessboard:
      return {o.cols + 1.0, o.rows + 1.0};
    case PatternType::kCharuco:
      return {static_cast<double>(o.cols), static_cast<double>(o.rows)};
    case PatternType::kCircles:
      return {o.cols - 1.0 + 1.0, o.rows - 1.0 + 1.0};
    case PatternType::kAsymmetricCircles:
      return {2.0 * (o.cols - 1) + 1.0 + 1.0, o.rows - 1.0 + 1.0};
  }
  return {};
}

}  // namespace

void TargetOptions::Check() const {
  CheckOption(cols >= 2 && rows >= 2, "TargetOptions.cols", cols, "cols and rows must be >= 2");
  CheckOption(screen.width >= 64 && screen.height >= 64, "TargetOptions.screen.width", screen.width,
              "the screen must be at least 64x64 px");
  CheckOption(pixel_pitch_m > 0 && pixel_pitch_m < 0.01, "TargetOptions.pixel_pitch_m",
              pixel_pitch_m, "must be in (0, 0.01) m");
  CheckOption(square_px >= 0, "TargetOptions.square_px", square_px,
              "must be >= 0 (0 = largest that fits)");
  CheckOption(margin_px >= 0, "TargetOptions.margin_px", margin_px,
              "must be >= 0 (0 = one square)");
  CheckOption(marker_fraction > 0 && marker_fraction < 1, "TargetOptions.marker_fraction",
              marker_fraction, "must be in (0, 1)");
  if (type == PatternType::kCharuco) {
    CheckOption(cols >= 3 && rows >= 3, "TargetOptions.cols", cols,
                "a ChArUco board needs >= 3x3 squares");
  }
}

RenderedTarget RenderTarget(const TargetOptions& options) {
  options.Check();
  const cv::Size2d extent = ExtentInSquares(options);
  RenderedTarget out;
  // With margin 0 the quiet zone is one square on each side.
  const double margin_squares = options.margin_px > 0 ? 0.0 : 2.0;
  int square = options.square_px;
  if (square == 0) {
    square = static_cast<int>(std::min(
        (options.screen.width - 2.0 * options.margin_px) / (extent.width + margin_squares),
        (options.screen.height - 2.0 * options.margin_px) / (extent.height + margin_squares)));
  }
  const int margin = options.margin_px > 0 ? options.margin_px : square;
  const int width = static_cast<int>(extent.width * square),
            height = static_cast<int>(extent.height * square);
  CheckOption(
      square >= 4 && width + 2 * margin <= options.screen.width &&
          height + 2 * margin <= options.screen.height,
      "TargetOptions.square_px", square,
      fmt::format(
          "the pattern ({}x{} squares plus margins) does not fit a {}x{} screen with squares of "
          "at least 4 px",
          extent.width, extent.height, options.screen.width, options.screen.height)
          .c_str());
  out.square_px = square;
  out.square_m = square * options.pixel_pitch_m;
  out.image = cv::Mat(options.screen, CV_8UC1, cv::Scalar(255));
  const int x0 = (options.screen.width - width) / 2, y0 = (options.screen.height - height) / 2;
  const cv::Mat board = out.image(cv::Rect(x0, y0, width, height));
  const std::string size = fmt::format("{:.9g}", out.square_m);
  switch (options.type) {
    case PatternType::kChessboard: {
      for (int r = 0; r <= options.rows; ++r) {
        for (int c = 0; c <= options.cols; ++c) {
          if ((r + c) % 2 == 0) board(cv::Rect(c * square, r * square, square, square)).setTo(0);
        }
      }
      // Inner corner (0, 0) lies on the pixel boundary between columns x0+square-1 and x0+square.
      out.origin_px = {x0 + square - 0.5, y0 + square - 0.5};
      out.pattern_spec = fmt::format("chessboard:{}x{}:{}", options.cols, options.rows, size);
      break;
    }
    case PatternType::kCharuco: {
      // Validates the dictionary name and the marker fraction with the same rules as --pattern.
      const PatternSpec spec =
          ParsePatternSpec(fmt::format("charuco:{}x{}:1:{}:{}", options.cols, options.rows,
                                       options.marker_fraction, options.dictionary));
      const auto charuco = cv::aruco::CharucoBoard::create(
          options.cols, options.rows, 1.0f, static_cast<float>(options.marker_fraction),
          cv::aruco::getPredefinedDictionary(ArucoDictionaryId(spec.dictionary)));
      cv::Mat drawn;
      charuco->draw(cv::Size(width, height), drawn, 0, 1);
      drawn.copyTo(board);
      out.marker_m = options.marker_fraction * out.square_m;
      out.origin_px = {x0 - 0.5,
                       y0 - 0.5};  // ChArUco board coordinates start at the board's corner
      out.pattern_spec = fmt::format("charuco:{}x{}:{}:{:.9g}:{}", options.cols, options.rows, size,
                                     out.marker_m, spec.dictionary);
      break;
    }
    case PatternType::kCircles:
    case PatternType::kAsymmetricCircles: {
      const bool asymmetric = options.type == PatternType::kAsymmetricCircles;
      constexpr int kShift = 4;  // sub-pixel centres for cv::circle
      const double radius = asymmetric ? 0.35 * square : 0.3 * square;
      for (int r = 0; r < options.rows; ++r) {
        for (int c = 0; c < options.cols; ++c) {
          const double x = (asymmetric ? 2 * c + r % 2 : c) * square + 0.5 * square - 0.5;
          const double y = r * square + 0.5 * square - 0.5;
          cv::circle(board, cv::Point(cvRound(x * (1 << kShift)), cvRound(y * (1 << kShift))),
                     cvRound(radius * (1 << kShift)), cv::Scalar(0), cv::FILLED, cv::LINE_AA,
                     kShift);
        }
      }
      out.origin_px = {x0 + 0.5 * square - 0.5, y0 + 0.5 * square - 0.5};
      out.pattern_spec = fmt::format("{}:{}x{}:{}", asymmetric ? "acircles" : "circles",
                                     options.cols, options.rows, size);
      break;
    }
  }
  return out;
}

}  // namespace linesight::calib
