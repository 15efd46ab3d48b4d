#include "linesight/demo/demo.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "linesight/core/error.h"
#include "linesight/core/timer.h"
#include "linesight/geometry/point_cloud.h"
#include "linesight/io/annotate.h"
#include "linesight/io/disparity_io.h"
#include "linesight/io/image_io.h"
#include "linesight/io/json_io.h"
#include "linesight/io/pfm.h"
#include "linesight/io/stereo_calibration.h"
#include "linesight/ranging/pipeline.h"
#include "linesight/ranging/ranging_settings.h"
#include "linesight/sim/board_calibration.h"

namespace linesight {
namespace fs = std::filesystem;

void DemoOptions::Check() const {
  CheckOption(!out_dir.empty(), "DemoOptions.out_dir", "(empty)", "name an output folder");
  CheckOption(!obstacles.empty(), "DemoOptions.obstacles", "(none)", "give at least one obstacle");
  CheckOption(board_views >= 3, "DemoOptions.board_views", board_views, "must be >= 3");
  CheckOption(min_depth_m > 0 && max_depth_m > min_depth_m, "DemoOptions.min_depth_m/max_depth_m",
              fmt::format("{}..{}", min_depth_m, max_depth_m), "need 0 < min < max");
  CheckOption(threads >= 0, "DemoOptions.threads", threads, "must be >= 0");
  calib::ParseMethod(calibration_method);
}

namespace {

void Log(std::FILE* log, const std::string& text) {
  if (!log) return;
  std::fprintf(log, "%s\n", text.c_str());
  std::fflush(log);
}

// The true box lives in the renderer's rectified frame; the estimated calibration rectifies
// slightly differently, so the ROI gets a margin.
cv::Rect DilateRoi(const cv::Rect& box, cv::Size image) {
  return GrowRoiByPixels(box, std::max(6, box.width / 6), std::max(6, box.height / 6), image);
}

// Calibrates from rendered boards (sim::CalibrateFromRenderedBoards) and writes them to `dir`.
void CalibrateFromBoards(const DemoOptions& options, const fs::path& dir, nlohmann::json* json,
                         StereoCalibration* out, std::FILE* log) {
  sim::CalibrationBoardOptions board_options;
  board_options.seed = options.seed;
  board_options.num_stereo_views = options.board_views;
  const sim::BoardCalibration calibration = sim::CalibrateFromRenderedBoards(
      board_options, calib::ParseMethod(options.calibration_method));
  const sim::CalibrationBoardSet& boards = calibration.boards;
  const calib::StereoDetections& detections = calibration.detections;
  const calib::CalibrationReport& report = calibration.report;
  fs::create_directories(dir);
  sim::WriteCalibrationBoards(dir, boards);
  *out = report.calibration;
  const StereoCalibration& truth = boards.calibration;
  const double true_baseline = cv::norm(truth.T);
  const double est_baseline = cv::norm(out->T);
  (*json)["calibration"] = {{"method", options.calibration_method},
                            {"views_detected_both", detections.BothCount()},
                            {"views_rendered", boards.views.size()},
                            {"stereo_rms_px", report.stereo_rms_px},
                            {"epipolar_mean_abs_dy_px", report.epipolar_mean_abs_dy_px},
                            {"reconstruction_percent", report.reconstruction_percent},
                            {"fx_left_true", truth.M1.at<double>(0, 0)},
                            {"fx_left_estimated", out->M1.at<double>(0, 0)},
                            {"baseline_true_m", true_baseline},
                            {"baseline_estimated_m", est_baseline}};
  Log(log, fmt::format(
               "  calibration ({}): {} of {} views detected in both cameras, stereo RMS {:.3f} px, "
               "fx {:.2f} (true {:.2f}), baseline {:.2f} mm (true {:.2f})",
               options.calibration_method, detections.BothCount(), boards.views.size(),
               report.stereo_rms_px, out->M1.at<double>(0, 0), truth.M1.at<double>(0, 0),
               est_baseline * 1000, true_baseline * 1000));
}

}  // namespace

std::string DemoReport::Table() const {
  std::string out =
      "| obstacle | true distance (m) | measured (m) | sigma (m) | error | auto-found (m) |\n"
      "|---|---|---|---|---|---|\n";
  for (const DemoObstacleRow& r : rows) {
    if (r.measured) {
      out += fmt::format("| {} | {:.3f} | {:.3f} | {:.3f} | {:+.2f} % | {} |\n", r.type,
                         r.true_distance_m, r.distance_m, r.sigma_m, r.error_percent,
                         r.auto_found ? fmt::format("{:.3f}", r.auto_distance_m) : "not found");
    } else {
      out += fmt::format("| {} | {:.3f} | no measurement ({}) | | | {} |\n", r.type,
                         r.true_distance_m, r.reason,
                         r.auto_found ? fmt::format("{:.3f}", r.auto_distance_m) : "not found");
    }
  }
  return out;
}

DemoReport RunDemo(const DemoOptions& options, std::FILE* log) {
  options.Check();
  fs::create_directories(options.out_dir);
  Stopwatch total;
  DemoReport report;
  nlohmann::json& json = report.json;

  // 1. Calibration from rendered boards (or the true calibration).
  Stopwatch watch;
  sim::PowerLineSceneOptions scene_options;
  scene_options.seed = options.seed;
  scene_options.obstacles = options.obstacles;
  StereoCalibration calibration;
  if (options.use_true_calibration) {
    calibration = sim::MakeStereoCalibration(scene_options.rig);
    json["calibration"] = {{"method", "true"}};
    Log(log, "  calibration: the renderer's true calibration");
  } else {
    Log(log, fmt::format("  rendering {} calibration board views and calibrating...",
                         options.board_views));
    CalibrateFromBoards(options, options.out_dir / "boards", &json, &calibration, log);
  }
  WriteStereoCalibration(options.out_dir / "stereo.yml", calibration);
  json["timing_ms"]["calibration"] = watch.ElapsedMs();

  // 2. The scene.
  watch.Restart();
  const sim::PowerLineScene scene = sim::RenderPowerLineScene(scene_options);
  sim::WritePowerLineScene(options.out_dir / "scene", scene);
  json["timing_ms"]["render"] = watch.ElapsedMs();
  Log(log, fmt::format("  rendered the scene ({}x{}, {} obstacles) in {:.0f} ms", scene.left.cols,
                       scene.left.rows, scene.obstacles.size(), watch.ElapsedMs()));

  // 3. Rectify + match + range.
  watch.Restart();
  RangingPipelineOptions pipeline_options;
  pipeline_options.method = options.method;
  pipeline_options.threads = options.threads;
  pipeline_options.min_depth_m = options.min_depth_m;
  pipeline_options.max_depth_m = options.max_depth_m;
  const RangingPipeline pipeline(calibration, pipeline_options);
  const RangingFrame frame = pipeline.Process(scene.left, scene.right);
  const double match_ms = watch.ElapsedMs();
  watch.Restart();
  std::vector<cv::Rect> rois;
  for (const sim::RenderedObstacle& o : scene.obstacles)
    rois.push_back(DilateRoi(o.box, frame.disparity.size()));
  const std::vector<RangeResult> measured = pipeline.RangeRois(frame, rois);
  const std::vector<RangeResult> found = pipeline.RangeAuto(frame);
  json["timing_ms"]["rectify_and_match"] = match_ms;
  json["timing_ms"]["ranging"] = watch.ElapsedMs();
  Log(log, fmt::format("  rectified and matched with {} ({} disparities from {}) in {:.0f} ms",
                       pipeline.method(), pipeline.search_range().num_disparities,
                       pipeline.search_range().min_disparity, match_ms));

  // 4. Compare with the truth.
  nlohmann::json obstacles = nlohmann::json::array();
  for (size_t i = 0; i < scene.obstacles.size(); ++i) {
    const sim::RenderedObstacle& truth = scene.obstacles[i];
    DemoObstacleRow row;
    row.type = sim::ObstacleTypeName(truth.type);
    row.true_distance_m = truth.distance_m;
    row.measured = measured[i].ok();
    row.reason = measured[i].reason;
    row.distance_m = measured[i].distance_m;
    row.sigma_m = measured[i].sigma_m;
    row.error_percent =
        row.measured ? 100.0 * (row.distance_m - row.true_distance_m) / row.true_distance_m : 0;
    // The automatic region that matches this obstacle best: the largest intersection over union
    // with the obstacle's true box (not the grown ROI, which large far regions would overlap).
    double best_overlap = 0.0;
    for (const RangeResult& r : found) {
      if (!r.ok()) continue;
      const double overlap =
          double((r.box & truth.box).area()) / double((r.box | truth.box).area());
      if (overlap > best_overlap) {
        best_overlap = overlap;
        row.auto_found = true;
        row.auto_distance_m = r.distance_m;
      }
    }
    nlohmann::json o = RangeResultToJson(measured[i]);
    o["type"] = row.type;
    o["true_distance_m"] = row.true_distance_m;
    o["error_percent"] = row.error_percent;
    o["auto_found"] = row.auto_found;
    if (row.auto_found) o["auto_distance_m"] = row.auto_distance_m;
    obstacles.push_back(o);
    report.rows.push_back(row);
  }
  json["obstacles"] = obstacles;
  nlohmann::json auto_json = nlohmann::json::array();
  for (const RangeResult& r : found) auto_json.push_back(RangeResultToJson(r));
  json["auto_found"] = auto_json;
  json["method"] = pipeline.method();
  json["matcher"] = pipeline.matcher().Settings();
  json["ranging_settings"] = RangingSettingsTable().ToJson(pipeline.options());
  json["distance_definition"] =
      "depth of the obstacle's nearest visible surface along the rectified left optical axis";

  // 5. Outputs for people.
  const DisparityRange& range = pipeline.disparity_range();
  cv::Mat colour = ColorizeDisparity(frame.disparity, static_cast<float>(range.min_disparity),
                                     static_cast<float>(range.max_disparity()));
  cv::Mat rectified = frame.left_rectified.clone();
  if (rectified.channels() == 1) cv::cvtColor(rectified, rectified, cv::COLOR_GRAY2BGR);
  std::vector<cv::Rect> boxes;
  std::vector<std::string> labels;
  for (size_t i = 0; i < report.rows.size(); ++i) {
    const DemoObstacleRow& row = report.rows[i];
    labels.push_back(row.measured ? fmt::format("{} {:.2f}+-{:.2f} m (true {:.2f})", row.type,
                                                row.distance_m, row.sigma_m, row.true_distance_m)
                                  : fmt::format("{}: no measurement", row.type));
    boxes.push_back(measured[i].ok() ? measured[i].box : rois[i]);
  }
  DrawLabelledBoxes(colour, boxes, labels, cv::Scalar(255, 255, 255));
  DrawLabelledBoxes(rectified, boxes, labels, cv::Scalar(0, 255, 255));
  WriteImage(options.out_dir / "left.png", scene.left);
  WriteImage(options.out_dir / "right.png", scene.right);
  WriteImage(options.out_dir / "rectified_left_ranged.png", rectified);
  WriteImage(options.out_dir / "disparity.png", colour);
  WritePfm(options.out_dir / "disparity.pfm", frame.disparity);
  CloudOptions cloud_options;
  cloud_options.max_depth_m = options.max_depth_m * 1.5;
  WritePly(options.out_dir / "cloud.ply",
           MakePointCloud(frame.disparity, pipeline.rectified_calibration(), frame.left_rectified,
                          cloud_options));
  json["timing_ms"]["total"] = total.ElapsedMs();
  WriteJson(options.out_dir / "report.json", json);
  return report;
}

}  // namespace linesight
