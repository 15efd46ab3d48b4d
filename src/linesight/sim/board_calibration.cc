#include "linesight/sim/board_calibration.h"

#include <vector>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>  // the IMREAD_* flag values only

#include "linesight/core/error.h"
#include "linesight/io/image_codecs.h"

namespace linesight::sim {

namespace {

// The grey image that reading `bgr` back from a PNG file gives (ReadImage with ImageColor::kGray):
// libpng's RGB-to-grey conversion differs from cv::cvtColor's by one level on some pixels, and the
// detected corners with it.
cv::Mat GrayAsReadFromPng(const cv::Mat& bgr) {
  std::vector<uint8_t> png;
  cv::Mat gray;
  if (!linesight::detail::EncodePng(bgr, &png) ||
      linesight::detail::DecodePngOrJpeg(png, cv::IMREAD_GRAYSCALE, &gray) !=
          linesight::detail::DecodeStatus::kDecoded) {
    throw std::logic_error("a rendered board view did not pass through PNG");
  }
  return gray;
}

}  // namespace

BoardCalibration CalibrateFromRenderedBoards(const CalibrationBoardOptions& options,
                                             calib::CalibrationMethod method) {
  BoardCalibration out;
  out.boards = RenderCalibrationBoards(options);
  std::vector<cv::Mat> left, right;
  for (const BoardView& view : out.boards.views) {
    left.push_back(GrayAsReadFromPng(view.left));
    right.push_back(GrayAsReadFromPng(view.right));
  }
  const ChessboardOptions& board = out.boards.board;
  const calib::PatternSpec spec = calib::ParsePatternSpec(
      fmt::format("chessboard:{}x{}:{}", board.cols, board.rows, board.square_m));
  out.detections = calib::DetectStereoImages(left, right, spec, calib::DetectionOptions());
  if (out.detections.BothCount() < 3) {
    throw InputError(fmt::format("only {} of {} rendered board views were detected in both cameras",
                                 out.detections.BothCount(), out.boards.views.size()));
  }
  const calib::StereoObservations observations =
      calib::ObservationsFromDetections(out.detections, calib::MakeBoardGeometry(spec));
  calib::StereoCalibrationOptions calib_options;
  calib_options.method = method;
  out.estimate = calib::CalibrateStereo(observations, calib_options);
  out.report = calib::EvaluateCalibration(observations, out.estimate);
  return out;
}

}  // namespace linesight::sim
