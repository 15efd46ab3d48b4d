// The ranging accuracy study of `linesight eval ranging`: obstacles of the power-line scene
// (sim/power_line_scene.h) at known distances, each captured `runs` times with fresh sensor noise
// and ranged through RangingPipeline with the true calibration and/or one estimated from rendered
// boards (sim::CalibrateFromRenderedBoards); plus the metric depth check on Middlebury 2014
// Motorcycle (depth from the chain's matcher against depth from the ground truth).
//
// Distances: true = the scene's distance_m (the obstacle's nearest visible surface, depth along
// the rectified left optical axis); measured = RangeObstacle's distance_m on the obstacle's true
// box grown by 15 % + 6 px (GrowRoi).
#pragma once

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "linesight/ranging/pipeline.h"
#include "linesight/sim/power_line_scene.h"

namespace linesight {

class ProgressBar;

// The calibration a cell's pipeline rectifies with.
enum class StudyCalibration {
  kTrue,       // the renderer's
  kEstimated,  // zhang on rendered boards (sim::CalibrateFromRenderedBoards)
};
std::string StudyCalibrationName(StudyCalibration calibration);  // "true", "estimated"
// "true" / "estimated"; UsageError otherwise.
StudyCalibration ParseStudyCalibration(const std::string& text);

struct RangingStudyOptions {
  int runs = 50;  // captures per type and distance, fresh sensor noise each
  std::vector<double> distances{0.3, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0,
                                3.5, 4.0, 4.5, 5.0, 5.5, 6.0};  // true distances (m)
  std::vector<sim::ObstacleType> types{sim::ObstacleType::kDamper,
                                       sim::ObstacleType::kSuspensionClamp,
                                       sim::ObstacleType::kInsulatorString};
  std::vector<StudyCalibration> calibrations{StudyCalibration::kTrue, StudyCalibration::kEstimated};
  int boards = 15;         // rendered board views for the estimated calibration
  std::uint64_t seed = 1;  // scene seed; the boards use seed + 1000
  double noise_dn = 1.0;   // sensor read noise (DN)
  int supersampling = 2;   // renderer rays per pixel side
  // Rig mounting and background, as in `linesight demo` (PowerLineSceneOptions' fields).
  double conductor_offset_x_m = sim::PowerLineSceneOptions().conductor_offset_x_m;
  double conductor_offset_y_m = sim::PowerLineSceneOptions().conductor_offset_y_m;
  double conductor_yaw_rad = sim::PowerLineSceneOptions().conductor_yaw_rad;
  double tower_offset_x_m = sim::PowerLineSceneOptions().tower_offset_x_m;
  RangingPipelineOptions pipeline;  // the chain every cell ranges with
  // Middlebury 2014 scene folder of the metric depth check; empty = no check.
  std::filesystem::path middlebury_dir =
      std::filesystem::path(LINESIGHT_SHARED_DATA_DIR) / "middlebury-2014-quarter/Motorcycle";
  // Log one line per run and calibration (truth, measured, the estimator on the ground-truth
  // disparity, the matcher's disparity error on the obstacle's nearest-surface pixels, the
  // calibration's own depth error at the nearest point), for finding a cell's bias.
  bool diagnose = false;

  void Check() const;
};

// Repeated measurements of one obstacle type at one distance with one calibration.
struct RangingStudyCell : RangeRunStats {
  std::string calibration, type;
  double truth_m = 0.0;
  double relative_error() const { return (mean_m - truth_m) / truth_m; }
};

// The calibration estimated from the rendered boards, against the true one.
struct StudyEstimatedCalibration {
  int views_rendered = 0, views_used = 0;  // used: detected in both cameras
  double rms_stereo_px = 0.0;
  double baseline_m = 0.0, true_baseline_m = 0.0;
  double rectified_focal_px = 0.0, true_rectified_focal_px = 0.0;
};

// Zhang on `views` rendered board views of `rig` (sim::CalibrateFromRenderedBoards), rectified;
// fills `info`. Throws InputError when too few views are detected.
StereoCalibration EstimateStudyCalibration(const sim::StereoRigOptions& rig, int views,
                                           std::uint64_t seed, StudyEstimatedCalibration* info);

// Depth Z = baseline * f / (d + doffs) from the chain's matcher against Z from the ground truth on
// the non-occluded pixels of a Middlebury 2014 scene.
struct MiddleburyDepthCheck {
  bool ran = false;
  std::string reason;  // why it did not run
  double median_relative_error = 0.0, mean_relative_error = 0.0;
  double density = 0.0;           // share of the evaluated pixels with an estimate
  double within_1_percent = 0.0;  // share of the estimates within 1 % of the true depth
  int pixels = 0;                 // estimates compared
};

// The scene's calib.txt, images, ground truth and mask are read from `dir`; the check does not run
// (`reason` says why) when calib.txt is absent. Throws InputError for a malformed scene.
MiddleburyDepthCheck CheckMiddleburyDepth(const std::filesystem::path& dir,
                                          const RangingPipelineOptions& pipeline);

struct RangingStudyReport {
  std::string method;  // the chain's matcher
  DisparityRange disparity_range;
  nlohmann::json ranging_settings;  // every --ranging setting the chain ran with
  int runs = 0;
  std::vector<std::string> calibrations, types;  // names, in the order of the options
  std::vector<RangingStudyCell> cells;           // type-major, then distance, then calibration
  std::optional<StudyEstimatedCalibration> estimated_calibration;
  std::optional<MiddleburyDepthCheck> middlebury;  // absent without a Middlebury folder
  int scenes = 0;                                  // rendered scenes (types x distances x runs)
  double scenes_seconds = 0.0;  // time of the scenes, without the Middlebury check

  // The table of cells (markdown).
  std::string ToMarkdown() const;
  // The Middlebury check's result as the lines printed after the table ("" without the check).
  std::string MiddleburySummary() const;
  nlohmann::json ToJson() const;
  // SVG: relative error (%) against distance, one panel per calibration, one line per type.
  std::string ToSvg() const;
};

// Runs the study. `progress` advances once per scene and is finished after the last one; `log`
// (may be null) receives the estimated calibration, the runs without a measurement per cell and,
// with options.diagnose, the diagnosis lines. Throws OptionError for invalid options, InputError
// when the boards cannot be calibrated or the Middlebury scene is malformed.
RangingStudyReport RunRangingStudy(const RangingStudyOptions& options,
                                   ProgressBar* progress = nullptr, std::FILE* log = stderr);

}  // namespace linesight
