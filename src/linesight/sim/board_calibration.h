// A calibration estimated from rendered calibration boards, the chain `linesight calibrate` runs on
// photographs of a real board: RenderCalibrationBoards, chessboard detection in every view
// (calib::DetectStereoImages, default DetectionOptions), calib::CalibrateStereo and
// calib::EvaluateCalibration, which rectifies the estimate. Everything stays in memory; the
// estimate equals that of `linesight calibrate` on the boards written by WriteCalibrationBoards.
#pragma once

#include "linesight/calib/calibration_report.h"
#include "linesight/calib/pattern.h"
#include "linesight/calib/stereo_calibrator.h"
#include "linesight/sim/power_line_scene.h"

namespace linesight::sim {

struct BoardCalibration {
  CalibrationBoardSet boards;  // the rendered views and the true calibration
  calib::StereoDetections detections;
  calib::StereoCalibrationResult estimate;
  calib::CalibrationReport report;  // report.calibration: the estimate, rectified
};

// Throws InputError when fewer than 3 views are detected in both cameras.
BoardCalibration CalibrateFromRenderedBoards(const CalibrationBoardOptions& options,
                                             calib::CalibrationMethod method);

}  // namespace linesight::sim
