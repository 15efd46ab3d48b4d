#include "linesight/eval/ranging_study.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <utility>

#include <fmt/format.h>
#include <opencv2/calib3d.hpp>

#include "linesight/core/disparity.h"
#include "linesight/core/error.h"
#include "linesight/core/progress.h"
#include "linesight/core/timer.h"
#include "linesight/geometry/depth.h"
#include "linesight/io/image_io.h"
#include "linesight/io/middlebury_calib.h"
#include "linesight/io/pfm.h"
#include "linesight/ranging/ranging_settings.h"
#include "linesight/sim/board_calibration.h"

namespace linesight {

namespace fs = std::filesystem;

std::string StudyCalibrationName(StudyCalibration calibration) {
  return calibration == StudyCalibration::kTrue ? "true" : "estimated";
}

StudyCalibration ParseStudyCalibration(const std::string& text) {
  for (StudyCalibration c : {StudyCalibration::kTrue, StudyCalibration::kEstimated}) {
    if (StudyCalibrationName(c) == text) return c;
  }
  throw UsageError(fmt::format("unknown calibration '{}' (expected true, estimated)", text));
}

void RangingStudyOptions::Check() const {
  CheckOption(runs >= 1, "RangingStudyOptions.runs", runs, "must be >= 1");
  CheckOption(!distances.empty(), "RangingStudyOptions.distances", "empty",
              "needs at least one distance");
  for (double d : distances) {
    CheckOption(std::isfinite(d) && d > 0, "RangingStudyOptions.distances", d, "must be > 0 m");
  }
  CheckOption(!types.empty(), "RangingStudyOptions.types", "empty", "needs at least one type");
  CheckOption(!calibrations.empty(), "RangingStudyOptions.calibrations", "empty",
              "needs at least one calibration");
  CheckOption(boards >= 3, "RangingStudyOptions.boards", boards,
              "must be >= 3 (the calibration needs three views)");
  pipeline.Check();
}

// Calibration estimated from rendered chessboards with the calibrator of `linesight calibrate`
// (method zhang), as `linesight demo` does.
StereoCalibration EstimateStudyCalibration(const sim::StereoRigOptions& rig, int views,
                                           std::uint64_t seed, StudyEstimatedCalibration* info) {
  sim::CalibrationBoardOptions options;
  options.rig = rig;
  options.num_stereo_views = views;
  options.seed = seed;
  const sim::BoardCalibration estimate =
      sim::CalibrateFromRenderedBoards(options, calib::CalibrationMethod::kZhang);
  const StereoCalibration c = estimate.report.calibration;
  info->views_rendered = views;
  info->views_used = estimate.detections.BothCount();
  info->rms_stereo_px = estimate.report.stereo_rms_px;
  info->baseline_m = c.Baseline();
  info->true_baseline_m = estimate.boards.calibration.Baseline();
  info->rectified_focal_px = c.RectifiedFocal();
  info->true_rectified_focal_px = estimate.boards.calibration.RectifiedFocal();
  return c;
}

namespace {

RangingStudyCell SummariseRangingCell(const std::string& calibration, const std::string& type,
                                      double truth, const std::vector<RangeResult>& results,
                                      const std::vector<double>& truths) {
  RangingStudyCell s;
  static_cast<RangeRunStats&>(s) = SummariseRangeRuns(results, truths);
  s.calibration = calibration;
  s.type = type;
  s.truth_m = truth;
  return s;
}

// The calibration's share of a cell's error, apart from matching: the obstacle's nearest point
// (true depth, true rectified left pixel) is projected by the TRUE cameras into the raw images,
// then rectified by the calibration in use (cv::undistortPoints with its R1/P1, R2/P2); the depth
// from that exact disparity, and the residual vertical misalignment there. 0 for the true
// calibration (a check of this computation).
void LogCalibrationOnlyError(std::FILE* log, const sim::PowerLineScene& scene,
                             const sim::RenderedObstacle& obstacle,
                             const RangingPipeline& pipeline) {
  const StereoCalibration& tc = scene.calibration;
  const StereoCalibration& uc = pipeline.rectified_calibration();
  const double f = tc.P1.at<double>(0, 0), cx = tc.P1.at<double>(0, 2), cy = tc.P1.at<double>(1, 2);
  const double z = obstacle.distance_m;
  const cv::Mat xr = (cv::Mat_<double>(3, 1) << (obstacle.nearest_pixel.x - cx) * z / f,
                      (obstacle.nearest_pixel.y - cy) * z / f, z);
  const cv::Mat xl = tc.R1.t() * xr;  // raw left camera frame
  std::vector<cv::Point3d> pl{{xl.at<double>(0), xl.at<double>(1), xl.at<double>(2)}};
  std::vector<cv::Point2d> il, ir;
  cv::Mat rvec;
  cv::Rodrigues(tc.R, rvec);
  cv::projectPoints(pl, cv::Mat::zeros(3, 1, CV_64F), cv::Mat::zeros(3, 1, CV_64F), tc.M1, tc.D1,
                    il);
  cv::projectPoints(pl, rvec, tc.T, tc.M2, tc.D2, ir);
  std::vector<cv::Point2d> ul, ur;
  cv::undistortPoints(il, ul, uc.M1, uc.D1, uc.R1, uc.P1);
  cv::undistortPoints(ir, ur, uc.M2, uc.D2, uc.R2, uc.P2);
  const double dd = ul[0].x - ur[0].x;
  const double zc = pipeline.geometry().DepthFromDisparity(dd);
  std::fprintf(log,
               "  calibration only at the nearest pixel: d %.3f px -> %.4f m (%+.2f %%), "
               "vertical misalignment %+.3f px\n",
               dd, zc, 100.0 * (zc / z - 1.0), ul[0].y - ur[0].y);
}

// One line of RangingStudyOptions::diagnose. "gt-est" = RangeObstacle on the ground-truth
// disparity map (the estimator's definition error without matching error); "front" = the
// obstacle's pixels whose true depth lies within 1 % of the true distance (its nearest surface):
// how many there are, how many the ranging map has, and the median matched-minus-true disparity on
// them. The ground truth lives in the TRUE rectified frame, so the per-pixel comparison is exact
// for the true calibration only.
void LogRangingDiagnosis(std::FILE* log, const std::string& type, const std::string& calibration,
                         int run, const sim::PowerLineScene& scene,
                         const sim::RenderedObstacle& obstacle, const cv::Rect& roi,
                         const RangingPipeline& pipeline, const RangingFrame& frame,
                         const RangeResult& result) {
  const StereoGeometry truth_geometry = GeometryFromCalibration(scene.calibration);
  // The pipeline's ranging options (their depth range already widened as RangeRois uses it).
  const RangeResult gt =
      RangeObstacle(scene.disparity, truth_geometry, roi, pipeline.options().ranging);
  const cv::Mat& d = pipeline.RangingDisparity(frame);
  std::vector<float> errors;
  std::vector<cv::Point> front_pixels;
  int front = 0;
  for (int y = roi.y; y < roi.br().y; ++y) {
    for (int x = roi.x; x < roi.br().x; ++x) {
      if (scene.obstacle_mask.at<uchar>(y, x) != obstacle.id) continue;
      if (scene.depth.at<float>(y, x) > 1.01 * obstacle.distance_m) continue;
      ++front;
      front_pixels.push_back({x, y});
      if (IsValidDisparity(d.at<float>(y, x)))
        errors.push_back(d.at<float>(y, x) - scene.disparity.at<float>(y, x));
    }
  }
  double median_error = NAN;
  if (!errors.empty()) {
    std::nth_element(errors.begin(), errors.begin() + long(errors.size() / 2), errors.end());
    median_error = errors[errors.size() / 2];
  }
  const double true_d = truth_geometry.DisparityFromDepth(obstacle.distance_m);
  {
    const SurfaceRefinement gt_ref =
        RefineSurfaceDisparity(frame.left_rectified, frame.right_rectified, front_pixels,
                               result.matched_disparity_px, pipeline.options().surface);
    double mean_true = 0;
    for (const cv::Point& p : front_pixels) mean_true += scene.disparity.at<float>(p.y, p.x);
    mean_true /= std::max<size_t>(1, front_pixels.size());
    std::fprintf(
        log,
        "  surface refinement on the true front pixels: ok %d d %.3f (their true mean %.3f, "
        "max %.3f) sigma %.3f ncc %.3f n %d %s\n",
        int(gt_ref.ok), gt_ref.disparity_px, mean_true, true_d, gt_ref.sigma_px, gt_ref.ncc,
        gt_ref.pixels, gt_ref.reason.c_str());
  }
  std::fprintf(
      log,
      "diag %s %s run %d: truth %.4f m (d %.3f px) box %d,%d,%dx%d | measured %s %.4f m "
      "(%+.2f %%) d %.3f sigma_d %.3f sigma %.4f px_obst %d | gt-est %s %.4f m (%+.2f %%) "
      "d %.3f | front %d px, %zu matched, median err %+.3f px | refined %s (matched d "
      "%.3f, surface %zu "
      "px mean %.3f)\n",
      calibration.c_str(), type.c_str(), run, obstacle.distance_m, true_d, obstacle.box.x,
      obstacle.box.y, obstacle.box.width, obstacle.box.height, result.ok() ? "ok" : "--",
      result.distance_m,
      result.ok() ? 100.0 * (result.distance_m / obstacle.distance_m - 1.0) : 0.0,
      result.disparity_px, result.disparity_sigma_px, result.sigma_m, result.obstacle_pixels,
      gt.ok() ? "ok" : "--", gt.distance_m,
      gt.ok() ? 100.0 * (gt.distance_m / obstacle.distance_m - 1.0) : 0.0, gt.disparity_px, front,
      errors.size(), median_error, result.refinement.empty() ? "no" : result.refinement.c_str(),
      result.matched_disparity_px, result.surface_pixels.size(), result.surface_disparity_px);
  if (!result.ok()) std::fprintf(log, "  reason: %s\n", result.reason.c_str());
  LogCalibrationOnlyError(log, scene, obstacle, pipeline);
}

}  // namespace

MiddleburyDepthCheck CheckMiddleburyDepth(const fs::path& dir,
                                          const RangingPipelineOptions& pipeline) {
  MiddleburyDepthCheck out;
  if (!fs::exists(dir / "calib.txt")) {
    out.reason = fmt::format("{} not found", (dir / "calib.txt").string());
    return out;
  }
  const MiddleburyCalib calib = ReadMiddleburyCalib(dir / "calib.txt");
  if (calib.num_disparities == 0) {
    throw InputError(fmt::format("{}: no 'ndisp=' entry", (dir / "calib.txt").string()));
  }
  StereoGeometry g;
  g.focal_px = calib.focal_px;
  g.cx = calib.cx;
  g.cy = calib.cy;
  g.baseline_m = calib.baseline_mm / 1000.0;
  g.disparity_offset_px = calib.doffs_px;
  const cv::Mat left = ReadImage(dir / "im0.png", ImageColor::kColor);
  const cv::Mat right = ReadImage(dir / "im1.png", ImageColor::kColor);
  const cv::Mat gt = ReadPfm(dir / "disp0GT.pfm");
  const cv::Mat mask = ReadImage(dir / "mask0nocc.png", ImageColor::kGray);
  MatcherOptions mo;
  mo.min_disparity = 0;
  mo.num_disparities = calib.num_disparities;
  mo.threads = pipeline.threads;
  mo.params = RangingMatcherParams(pipeline.method, pipeline.params);  // the chain's settings
  auto matcher =
      CreateMatcher(pipeline.method.empty() ? DefaultMatcherName() : pipeline.method, mo);
  const cv::Mat disparity = matcher->Compute(left, right).disparity;
  const cv::Mat z = DepthFromDisparity(disparity, g);
  const cv::Mat z_gt = DepthFromDisparity(gt, g);
  std::vector<float> errors;
  int evaluated = 0;
  for (int y = 0; y < gt.rows; ++y) {
    for (int x = 0; x < gt.cols; ++x) {
      if (mask.at<uchar>(y, x) != 255 || z_gt.at<float>(y, x) == kNoDepth) continue;
      ++evaluated;
      if (z.at<float>(y, x) == kNoDepth) continue;
      errors.push_back(std::abs(z.at<float>(y, x) - z_gt.at<float>(y, x)) / z_gt.at<float>(y, x));
    }
  }
  if (errors.empty()) {
    out.reason = "no pixel with both an estimate and ground truth";
    return out;
  }
  out.ran = true;
  out.pixels = int(errors.size());
  out.density = double(errors.size()) / double(evaluated);
  out.mean_relative_error =
      std::accumulate(errors.begin(), errors.end(), 0.0) / double(errors.size());
  out.within_1_percent =
      double(std::count_if(errors.begin(), errors.end(), [](float e) { return e <= 0.01f; })) /
      double(errors.size());
  std::nth_element(errors.begin(), errors.begin() + long(errors.size() / 2), errors.end());
  out.median_relative_error = errors[errors.size() / 2];
  return out;
}

RangingStudyReport RunRangingStudy(const RangingStudyOptions& options, ProgressBar* progress,
                                   std::FILE* log) {
  options.Check();
  std::vector<std::string> type_names;
  for (sim::ObstacleType type : options.types) type_names.push_back(sim::ObstacleTypeName(type));
  sim::PowerLineSceneOptions scene_options;
  scene_options.seed = options.seed;
  scene_options.sensor.noise_sigma_dn = options.noise_dn;
  scene_options.sensor.supersampling = options.supersampling;
  scene_options.conductor_offset_x_m = options.conductor_offset_x_m;
  scene_options.conductor_offset_y_m = options.conductor_offset_y_m;
  scene_options.conductor_yaw_rad = options.conductor_yaw_rad;
  scene_options.tower_offset_x_m = options.tower_offset_x_m;
  scene_options.Check();

  RangingStudyReport report;
  report.runs = options.runs;
  report.types = type_names;
  std::vector<std::pair<std::string, StereoCalibration>> calibs;
  for (StudyCalibration calibration : options.calibrations) {
    const std::string name = StudyCalibrationName(calibration);
    report.calibrations.push_back(name);
    if (calibration == StudyCalibration::kTrue) {
      calibs.emplace_back(name, sim::MakeStereoCalibration(scene_options.rig));
    } else {
      StudyEstimatedCalibration info;
      calibs.emplace_back(name, EstimateStudyCalibration(scene_options.rig, options.boards,
                                                         options.seed + 1000, &info));
      report.estimated_calibration = info;
      if (log) {
        std::fprintf(log, "estimated calibration: baseline %.5f m (true %.5f), rms %.3f px\n",
                     info.baseline_m, info.true_baseline_m, info.rms_stereo_px);
      }
    }
  }
  std::vector<RangingPipeline> pipelines;
  for (const auto& [name, calib] : calibs) pipelines.emplace_back(calib, options.pipeline);
  report.method = pipelines.front().method();
  report.disparity_range = pipelines.front().disparity_range();
  report.ranging_settings = RangingSettingsTable().ToJson(options.pipeline);

  Stopwatch watch;
  for (size_t t = 0; t < options.types.size(); ++t) {
    for (double distance : options.distances) {
      std::vector<std::vector<RangeResult>> results(calibs.size());
      std::vector<double> truths;
      sim::PowerLineSceneOptions o = scene_options;
      o.obstacles = {{options.types[t], distance, 0}};
      const sim::PowerLineSceneRenderer renderer(o);  // ray cast once, fresh sensor noise per run
      for (int run = 0; run < options.runs; ++run) {
        const sim::PowerLineScene scene = renderer.Capture(std::uint64_t(run) * 7919 + 17);
        const sim::RenderedObstacle& obstacle = scene.obstacles.front();
        truths.push_back(obstacle.distance_m);
        const cv::Rect roi = GrowRoi(obstacle.box, scene.left.size());
        for (size_t c = 0; c < calibs.size(); ++c) {
          const RangingFrame frame =
              pipelines[c].Process(scene.left, scene.right, cv::Range(roi.y, roi.br().y));
          results[c].push_back(pipelines[c].RangeRois(frame, {roi}).front());
          if (options.diagnose && log) {
            LogRangingDiagnosis(log, type_names[t], calibs[c].first, run, scene, obstacle, roi,
                                pipelines[c], frame, results[c].back());
          }
        }
        if (progress) progress->Advance();
      }
      for (size_t c = 0; c < calibs.size(); ++c) {
        report.cells.push_back(
            SummariseRangingCell(calibs[c].first, type_names[t], distance, results[c], truths));
      }
    }
  }
  if (progress) progress->Finish();
  report.scenes = static_cast<int>(options.types.size() * options.distances.size()) * options.runs;
  report.scenes_seconds = watch.ElapsedMs() / 1000.0;
  if (log) {
    for (const RangingStudyCell& c : report.cells) {
      for (const auto& [reason, count] : c.failures) {
        std::fprintf(log, "%s %s %.2f m: %d run(s) without a measurement: %s\n",
                     c.calibration.c_str(), c.type.c_str(), c.truth_m, count, reason.c_str());
      }
    }
  }
  if (!options.middlebury_dir.empty()) {
    report.middlebury = CheckMiddleburyDepth(options.middlebury_dir, options.pipeline);
  }
  return report;
}

std::string RangingStudyReport::ToMarkdown() const {
  std::string table = fmt::format(
      "| calibration | type | true m | runs | measured | mean m | abs err m | rel err % | mean "
      "abs rel % | std m | "
      "mean sigma m | within 2 sigma % |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const RangingStudyCell& c : cells) {
    table += fmt::format(
        "| {} | {} | {:.2f} | {} | {} | {:.4f} | {:+.4f} | {:+.2f} | {:.2f} | {:.4f} | {:.4f} | "
        "{:.0f} |\n",
        c.calibration, c.type, c.truth_m, c.runs, c.measured, c.mean_m, c.mean_m - c.truth_m,
        100.0 * c.relative_error(), 100.0 * c.mean_abs_relative, c.std_m, c.mean_sigma_m,
        c.measured ? 100.0 * c.covered / c.measured : 0.0);
  }
  return table;
}

std::string RangingStudyReport::MiddleburySummary() const {
  if (!middlebury) return "";
  const MiddleburyDepthCheck& check = *middlebury;
  if (!check.ran) return "\nMiddlebury check skipped: " + check.reason + "\n";
  return fmt::format(
      "\nMiddlebury 2014 Motorcycle (quarter), {}: depth Z = baseline*f/(d + doffs) from our "
      "disparity vs from "
      "the ground truth, non-occluded pixels: median relative error {:.2f} %, mean {:.2f} %, "
      "within 1 %: "
      "{:.1f} % of {} pixels (density {:.1f} %)\n",
      method, 100.0 * check.median_relative_error, 100.0 * check.mean_relative_error,
      100.0 * check.within_1_percent, check.pixels, 100.0 * check.density);
}

nlohmann::json RangingStudyReport::ToJson() const {
  nlohmann::json report;
  report["distance_definition"] =
      "true: the sim's distance_m (nearest visible surface, depth along the rectified left "
      "optical axis); "
      "measured: RangeObstacle distance_m on the obstacle's ground-truth box grown by 15 % + 6 "
      "px";
  if (estimated_calibration) {
    const StudyEstimatedCalibration& e = *estimated_calibration;
    report["estimated_calibration"] = {
        {"method", "zhang (calib::CalibrateStereo + calib::EvaluateCalibration)"},
        {"views_rendered", e.views_rendered},
        {"views_used", e.views_used},
        {"rms_stereo_px", e.rms_stereo_px},
        {"baseline_m", e.baseline_m},
        {"true_baseline_m", e.true_baseline_m},
        {"baseline_relative_error", (e.baseline_m - e.true_baseline_m) / e.true_baseline_m},
        {"rectified_focal_px", e.rectified_focal_px},
        {"true_rectified_focal_px", e.true_rectified_focal_px}};
  }
  report["method"] = method;
  report["ranging_settings"] = ranging_settings;
  report["disparity_range"] = {disparity_range.min_disparity, disparity_range.max_disparity()};
  report["runs"] = runs;
  report["cells"] = nlohmann::json::array();
  for (const RangingStudyCell& c : cells) {
    report["cells"].push_back(
        {{"calibration", c.calibration},
         {"type", c.type},
         {"true_distance_m", c.truth_m},
         {"runs", c.runs},
         {"measured", c.measured},
         {"mean_distance_m", c.mean_m},
         {"abs_error_m", c.mean_m - c.truth_m},
         {"relative_error", c.relative_error()},
         {"mean_abs_relative_error", c.mean_abs_relative},
         {"std_m", c.std_m},
         {"mean_sigma_m", c.mean_sigma_m},
         {"coverage_2sigma", c.measured ? double(c.covered) / c.measured : 0.0},
         {"no_measurement_reasons", c.failures}});
  }
  if (middlebury) {
    const MiddleburyDepthCheck& check = *middlebury;
    if (check.ran) {
      report["middlebury_motorcycle"] = {{"median_relative_error", check.median_relative_error},
                                         {"mean_relative_error", check.mean_relative_error},
                                         {"within_1_percent", check.within_1_percent},
                                         {"pixels", check.pixels},
                                         {"density", check.density}};
    } else {
      report["middlebury_motorcycle"] = {{"skipped", check.reason}};
    }
  }
  return report;
}

std::string RangingStudyReport::ToSvg() const {
  double max_distance = 0.0;
  for (const RangingStudyCell& c : cells) max_distance = std::max(max_distance, c.truth_m);
  max_distance = std::ceil(max_distance);
  const int panel_w = 460, panel_h = 300, left = 60, top = 40, gap = 40;
  const int width = left + int(calibrations.size()) * (panel_w + gap) + 20,
            height = top + panel_h + 80;
  double max_abs = 1.0;  // percent
  for (const RangingStudyCell& c : cells) {
    if (c.measured > 0) max_abs = std::max(max_abs, std::abs(100.0 * c.relative_error()));
  }
  max_abs = std::min(std::ceil(max_abs), 20.0);
  const char* colours[] = {"#d62728", "#1f77b4", "#2ca02c", "#9467bd"};
  std::string svg = fmt::format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{}\" height=\"{}\" "
      "font-family=\"sans-serif\" "
      "font-size=\"12\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n",
      width, height);
  for (size_t p = 0; p < calibrations.size(); ++p) {
    const int x0 = left + int(p) * (panel_w + gap);
    auto px = [&](double d) { return x0 + d / max_distance * panel_w; };
    auto py = [&](double e) { return top + panel_h / 2.0 - e / max_abs * (panel_h / 2.0); };
    svg += fmt::format(
        "<text x=\"{}\" y=\"{}\" font-size=\"14\">relative error (%) vs distance, {} "
        "calibration</text>\n",
        x0, top - 15, calibrations[p]);
    svg += fmt::format(
        "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"black\"/>\n", x0,
        top, panel_w, panel_h);
    for (double e : {-1.0, 1.0}) {  // the 1 % goal
      svg += fmt::format(
          "<line x1=\"{}\" y1=\"{:.1f}\" x2=\"{}\" y2=\"{:.1f}\" stroke=\"#999\" "
          "stroke-dasharray=\"4,3\"/>\n",
          x0, py(e), x0 + panel_w, py(e));
    }
    svg += fmt::format("<line x1=\"{}\" y1=\"{:.1f}\" x2=\"{}\" y2=\"{:.1f}\" stroke=\"#ccc\"/>\n",
                       x0, py(0), x0 + panel_w, py(0));
    for (int d = 0; d <= int(max_distance); ++d) {
      svg += fmt::format("<text x=\"{:.1f}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n", px(d),
                         top + panel_h + 16, d);
    }
    svg += fmt::format("<text x=\"{}\" y=\"{}\">distance (m)</text>\n", x0 + panel_w / 2 - 30,
                       top + panel_h + 34);
    for (double e : {-max_abs, -max_abs / 2, 0.0, max_abs / 2, max_abs}) {
      svg += fmt::format("<text x=\"{}\" y=\"{:.1f}\" text-anchor=\"end\">{:g}</text>\n", x0 - 4,
                         py(e) + 4, e);
    }
    for (size_t t = 0; t < types.size(); ++t) {
      std::string points;
      for (const RangingStudyCell& c : cells) {
        if (c.calibration != calibrations[p] || c.type != types[t] || c.measured == 0) continue;
        const double e = std::clamp(100.0 * c.relative_error(), -max_abs, max_abs);
        points += fmt::format("{:.1f},{:.1f} ", px(c.truth_m), py(e));
        svg += fmt::format("<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"3\" fill=\"{}\"/>\n",
                           px(c.truth_m), py(e), colours[t % 4]);
      }
      svg += fmt::format(
          "<polyline points=\"{}\" fill=\"none\" stroke=\"{}\" stroke-width=\"1.5\"/>\n", points,
          colours[t % 4]);
      svg += fmt::format("<text x=\"{}\" y=\"{}\" fill=\"{}\">{}</text>\n", x0 + 10 + int(t) * 110,
                         top + panel_h + 58, colours[t % 4], types[t]);
    }
  }
  svg += "</svg>\n";
  return svg;
}

}  // namespace linesight
