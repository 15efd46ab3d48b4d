// linesight eval ranging: the ranging accuracy study on rendered power-line scenes (true
// and estimated calibration), plus the metric depth check on Middlebury 2014 Motorcycle.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <numeric>
#include <regex>
#include <sstream>

#include <unistd.h>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "cli.h"
#include "commands.h"
#include "linesight/calib/calibration_report.h"
#include "linesight/calib/pattern.h"
#include "linesight/calib/stereo_calibrator.h"
#include "linesight/core/atomic_file.h"
#include "linesight/core/disparity.h"
#include "linesight/core/error.h"
#include "linesight/core/progress.h"
#include "linesight/core/timer.h"
#include "linesight/geometry/depth.h"
#include "linesight/io/image_io.h"
#include "linesight/io/json_io.h"
#include "linesight/io/pfm.h"
#include "linesight/ranging/pipeline.h"
#include "linesight/ranging/ranging_settings.h"
#include "linesight/sim/power_line_scene.h"

namespace linesight::cli {
namespace {

struct CellStats : RangeRunStats {
  std::string calibration, type;
  double truth_m = 0.0;
  double relative_error() const { return (mean_m - truth_m) / truth_m; }
};

CellStats Summarise(const std::string& calibration, const std::string& type, double truth,
                    const std::vector<RangeResult>& results, const std::vector<double>& truths) {
  CellStats s;
  static_cast<RangeRunStats&>(s) = SummariseRangeRuns(results, truths);
  s.calibration = calibration;
  s.type = type;
  s.truth_m = truth;
  return s;
}

// Calibration estimated from rendered chessboards with our calibrator, as `linesight demo` does:
// the boards are written to a scratch folder, detected (calib::DetectStereoPairs), calibrated with
// calib::CalibrateStereo (method zhang) and rectified by calib::EvaluateCalibration.
StereoCalibration EstimateCalibrationFromBoards(const sim::StereoRigOptions& rig, int views,
                                                std::uint64_t seed, nlohmann::json* info) {
  sim::CalibrationBoardOptions options;
  options.rig = rig;
  options.num_stereo_views = views;
  options.seed = seed;
  const sim::CalibrationBoardSet set = sim::RenderCalibrationBoards(options);
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() /
      fmt::format("linesight-eval-ranging-boards-{}-{}", ::getpid(), seed);
  std::filesystem::create_directories(dir);
  struct RemoveDir {
    std::filesystem::path path;
    ~RemoveDir() {
      std::error_code ignored;
      std::filesystem::remove_all(path, ignored);
    }
  } remove_dir{dir};
  sim::WriteCalibrationBoards(dir, set);
  std::vector<std::filesystem::path> left_paths, right_paths;
  for (size_t i = 0; i < set.views.size(); ++i) {
    left_paths.push_back(dir / fmt::format("left_{:02d}.png", i));
    right_paths.push_back(dir / fmt::format("right_{:02d}.png", i));
  }
  const calib::PatternSpec spec = calib::ParsePatternSpec(
      fmt::format("chessboard:{}x{}:{}", set.board.cols, set.board.rows, set.board.square_m));
  const calib::StereoDetections detections =
      calib::DetectStereoPairs(left_paths, right_paths, spec, calib::DetectionOptions(), false);
  if (detections.BothCount() < 3) {
    throw InputError(fmt::format("only {} of {} rendered board views were detected in both cameras",
                                 detections.BothCount(), views));
  }
  const calib::StereoObservations observations =
      calib::ObservationsFromDetections(detections, calib::MakeBoardGeometry(spec));
  calib::StereoCalibrationOptions calib_options;
  calib_options.method = calib::ParseMethod("zhang");
  const calib::StereoCalibrationResult estimate =
      calib::CalibrateStereo(observations, calib_options);
  const calib::CalibrationReport report = calib::EvaluateCalibration(observations, estimate);
  const StereoCalibration c = report.calibration;
  const double true_baseline = set.calibration.Baseline();
  (*info) = {{"method", "zhang (calib::CalibrateStereo + calib::EvaluateCalibration)"},
             {"views_rendered", views},
             {"views_used", detections.BothCount()},
             {"rms_stereo_px", report.stereo_rms_px},
             {"baseline_m", c.Baseline()},
             {"true_baseline_m", true_baseline},
             {"baseline_relative_error", (c.Baseline() - true_baseline) / true_baseline},
             {"rectified_focal_px", c.RectifiedFocal()},
             {"true_rectified_focal_px", set.calibration.RectifiedFocal()}};
  return c;
}

struct MiddleburyCheck {
  bool ran = false;
  std::string reason;
  double median_relative_error = 0.0, mean_relative_error = 0.0, density = 0.0,
         within_1_percent = 0.0;
  int pixels = 0;
};

double ReadCalibValue(const std::string& text, const std::string& key, const std::string& file) {
  const std::regex re(key + R"(=\s*([-0-9.eE+]+))");
  std::smatch m;
  if (!std::regex_search(text, m, re))
    throw InputError(fmt::format("{}: no '{}=' entry", file, key));
  return std::stod(m[1]);
}

MiddleburyCheck RunMiddleburyCheck(const std::filesystem::path& dir,
                                   const RangingPipelineOptions& base) {
  MiddleburyCheck out;
  if (!std::filesystem::exists(dir / "calib.txt")) {
    out.reason = fmt::format("{} not found", (dir / "calib.txt").string());
    return out;
  }
  const std::string calib_text = ReadTextFile(dir / "calib.txt");
  const std::regex cam_re(
      R"(cam0=\[\s*([-0-9.eE+]+)\s+[-0-9.eE+]+\s+([-0-9.eE+]+);\s*[-0-9.eE+]+\s+[-0-9.eE+]+\s+([-0-9.eE+]+))");
  std::smatch m;
  if (!std::regex_search(calib_text, m, cam_re)) throw InputError("calib.txt: cannot parse cam0");
  StereoGeometry g;
  g.focal_px = std::stod(m[1]);
  g.cx = std::stod(m[2]);
  g.cy = std::stod(m[3]);
  g.baseline_m = ReadCalibValue(calib_text, "baseline", "calib.txt") / 1000.0;
  g.disparity_offset_px = ReadCalibValue(calib_text, "doffs", "calib.txt");
  const int ndisp = int(ReadCalibValue(calib_text, "ndisp", "calib.txt"));
  const cv::Mat left = ReadImage(dir / "im0.png", ImageColor::kColor);
  const cv::Mat right = ReadImage(dir / "im1.png", ImageColor::kColor);
  const cv::Mat gt = ReadPfm(dir / "disp0GT.pfm");
  const cv::Mat mask = ReadImage(dir / "mask0nocc.png", ImageColor::kGray);
  MatcherOptions mo;
  mo.min_disparity = 0;
  mo.num_disparities = ndisp;
  mo.threads = base.threads;
  mo.params = RangingMatcherParams(base.method, base.params);  // the chain's settings
  auto matcher = CreateMatcher(base.method.empty() ? DefaultMatcherName() : base.method, mo);
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

std::string MakeSvgPlot(const std::vector<CellStats>& cells,
                        const std::vector<std::string>& calibrations,
                        const std::vector<std::string>& types, double max_distance) {
  const int panel_w = 460, panel_h = 300, left = 60, top = 40, gap = 40;
  const int width = left + int(calibrations.size()) * (panel_w + gap) + 20,
            height = top + panel_h + 80;
  double max_abs = 1.0;  // percent
  for (const CellStats& c : cells) {
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
      for (const CellStats& c : cells) {
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

// The calibration's share of a cell's error, apart from matching: the obstacle's nearest point
// (true depth, true rectified left pixel) is projected by the TRUE cameras into the raw images,
// then rectified by the calibration in use (cv::undistortPoints with its R1/P1, R2/P2); the depth
// from that exact disparity, and the residual vertical misalignment there. 0 for the true
// calibration (a check of this computation).
void PrintCalibrationOnlyError(const sim::PowerLineScene& scene,
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
  std::fprintf(stderr,
               "  calibration only at the nearest pixel: d %.3f px -> %.4f m (%+.2f %%), "
               "vertical misalignment %+.3f px\n",
               dd, zc, 100.0 * (zc / z - 1.0), ul[0].y - ur[0].y);
}

// One line of --diagnose. "gt-est" = RangeObstacle on the ground-truth disparity map (the
// estimator's definition error without matching error); "front" = the obstacle's pixels whose true
// depth lies within 1 % of the true distance (its nearest surface): how many there are, how many
// the ranging map has, and the median matched-minus-true disparity on them. The ground truth lives
// in the TRUE rectified frame, so the per-pixel comparison is exact for the true calibration only.
void PrintDiagnosis(const std::string& type, const std::string& calibration, int run,
                    const sim::PowerLineScene& scene, const sim::RenderedObstacle& obstacle,
                    const cv::Rect& roi, const RangingPipeline& pipeline, const RangingFrame& frame,
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
        stderr,
        "  surface refinement on the true front pixels: ok %d d %.3f (their true mean %.3f, "
        "max %.3f) sigma %.3f ncc %.3f n %d %s\n",
        int(gt_ref.ok), gt_ref.disparity_px, mean_true, true_d, gt_ref.sigma_px, gt_ref.ncc,
        gt_ref.pixels, gt_ref.reason.c_str());
  }
  std::fprintf(
      stderr,
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
  if (!result.ok()) std::fprintf(stderr, "  reason: %s\n", result.reason.c_str());
  PrintCalibrationOnlyError(scene, obstacle, pipeline);
}

std::vector<double> ParseDoubles(const std::string& text, const char* what) {
  std::vector<double> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    try {
      size_t used = 0;
      out.push_back(std::stod(item, &used));
      if (used != item.size()) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      throw UsageError(fmt::format("{}: '{}' is not a number", what, item));
    }
  }
  if (out.empty()) throw UsageError(fmt::format("{}: empty list", what));
  return out;
}

}  // namespace

int RunEvalRanging(int argc, char** argv) {
  CLI::App app{
      "Ranging accuracy study on rendered power-line scenes (true and estimated calibration) and "
      "the metric depth check on Middlebury 2014 Motorcycle.",
      "eval ranging"};
  std::string distances_text = "0.3,0.5,1.0,1.5,2.0,2.5,3.0,3.5,4.0,4.5,5.0,5.5,6.0";
  std::string types_text = "damper,clamp,insulator", calibrations_text = "true,estimated";
  std::string json_path, plot_path, markdown_path;
  std::string middlebury_dir =
      std::string(LINESIGHT_SHARED_DATA_DIR) + "/middlebury-2014-quarter/Motorcycle";
  int runs = 50, boards = 15, supersampling = 2;
  std::uint64_t seed = 1;
  double noise_dn = 1.0;
  // Rig mounting and background (defaults: the scene's, as in `linesight demo`).
  double conductor_offset_x_m = sim::PowerLineSceneOptions().conductor_offset_x_m;
  double tower_offset_x_m = sim::PowerLineSceneOptions().tower_offset_x_m;
  double conductor_offset_y_m = sim::PowerLineSceneOptions().conductor_offset_y_m;
  double conductor_yaw_rad = sim::PowerLineSceneOptions().conductor_yaw_rad;
  std::vector<std::string> raw_params, ranging_settings;
  RangingPipelineOptions options;
  app.add_option("--runs", runs, "measurements per type and distance (fresh sensor noise each)")
      ->capture_default_str();
  app.add_option("--distances", distances_text, "true distances (m), comma separated")
      ->capture_default_str();
  app.add_option("--types", types_text, "obstacle types: damper, clamp, insulator")
      ->capture_default_str();
  app.add_option("--calibrations", calibrations_text,
                 "true and/or estimated (from rendered boards)")
      ->capture_default_str();
  app.add_option("--boards", boards, "rendered board views for the estimated calibration")
      ->capture_default_str();
  app.add_option("--seed", seed, "scene seed")->capture_default_str();
  app.add_option("--noise", noise_dn, "sensor read noise (DN)")->capture_default_str();
  app.add_option("--conductor-offset-x", conductor_offset_x_m,
                 "x of the conductor axis at the camera, in the left camera frame (m); 0.06 = rig "
                 "centred under the line")
      ->capture_default_str();
  app.add_option("--conductor-offset-y", conductor_offset_y_m,
                 "y of the conductor axis at the camera (m; < 0 = above the camera)")
      ->capture_default_str();
  app.add_option("--conductor-yaw", conductor_yaw_rad,
                 "heading of the line about the camera y axis (rad)")
      ->capture_default_str();
  app.add_option("--tower-offset-x", tower_offset_x_m,
                 "x offset of the end tower's body from the middle of the conductors (m)")
      ->capture_default_str();
  app.add_option("--supersampling", supersampling, "renderer supersampling per axis")
      ->capture_default_str();
  app.add_option("--method", options.method,
                 fmt::format("matcher (default {})", DefaultMatcherName()));
  AddParamOption(app, &raw_params);
  app.add_option("--min-depth", options.min_depth_m, "working range (m)")->capture_default_str();
  app.add_option("--max-depth", options.max_depth_m, "working range (m)")->capture_default_str();
  app.add_option("--threads", options.threads, "matcher threads (0 = all)")->capture_default_str();
  app.add_option("--middlebury", middlebury_dir, "Middlebury 2014 scene folder ('' to skip)")
      ->capture_default_str();
  AddRangingSettingsOption(app, &ranging_settings);
  app.add_option("--json", json_path, "report (- for stdout)");
  app.add_option("--plot", plot_path, "SVG plot of relative error vs distance");
  app.add_option("--markdown", markdown_path, "write the table as Markdown too");
  bool diagnose = false;
  app.add_flag("--diagnose", diagnose,
               "print one line per run and calibration to stderr: truth, measured, the same "
               "estimator on the ground-truth disparity, and the matcher's disparity error on the "
               "obstacle's nearest-surface pixels, and the calibration's own depth error at the "
               "nearest point (for finding a cell's bias)");
  return RunCommand(app, argc, argv, [&] {
    if (runs < 1) throw UsageError("--runs must be >= 1");
    options.params = ParseParams(raw_params);
    ApplyRangingSettings("--ranging", ranging_settings, &options);
    const std::vector<double> distances = ParseDoubles(distances_text, "--distances");
    std::vector<sim::ObstacleType> types;
    std::vector<std::string> type_names;
    {
      std::stringstream ss(types_text);
      std::string item;
      while (std::getline(ss, item, ',')) {
        types.push_back(sim::ParseObstacleType(item));
        type_names.push_back(sim::ObstacleTypeName(types.back()));
      }
    }
    std::vector<std::string> calibrations;
    {
      std::stringstream ss(calibrations_text);
      std::string item;
      while (std::getline(ss, item, ',')) {
        if (item != "true" && item != "estimated") {
          throw UsageError(fmt::format("--calibrations: '{}' (expected true, estimated)", item));
        }
        calibrations.push_back(item);
      }
    }
    sim::PowerLineSceneOptions scene_options;
    scene_options.seed = seed;
    scene_options.sensor.noise_sigma_dn = noise_dn;
    scene_options.sensor.supersampling = supersampling;
    scene_options.conductor_offset_x_m = conductor_offset_x_m;
    scene_options.conductor_offset_y_m = conductor_offset_y_m;
    scene_options.conductor_yaw_rad = conductor_yaw_rad;
    scene_options.tower_offset_x_m = tower_offset_x_m;
    scene_options.Check();
    const StereoCalibration true_calib = sim::MakeStereoCalibration(scene_options.rig);
    nlohmann::json report;
    report["distance_definition"] =
        "true: the sim's distance_m (nearest visible surface, depth along the rectified left "
        "optical axis); "
        "measured: RangeObstacle distance_m on the obstacle's ground-truth box grown by 15 % + 6 "
        "px";
    std::vector<std::pair<std::string, StereoCalibration>> calibs;
    for (const std::string& name : calibrations) {
      if (name == "true") {
        calibs.emplace_back(name, true_calib);
      } else {
        nlohmann::json info;
        calibs.emplace_back(
            name, EstimateCalibrationFromBoards(scene_options.rig, boards, seed + 1000, &info));
        report["estimated_calibration"] = info;
        std::fprintf(stderr, "estimated calibration: baseline %.5f m (true %.5f), rms %.3f px\n",
                     info["baseline_m"].get<double>(), info["true_baseline_m"].get<double>(),
                     info["rms_stereo_px"].get<double>());
      }
    }
    std::vector<RangingPipeline> pipelines;
    for (const auto& [name, calib] : calibs) pipelines.emplace_back(calib, options);
    report["method"] = pipelines.front().method();
    report["disparity_range"] = {pipelines.front().disparity_range().min_disparity,
                                 pipelines.front().disparity_range().max_disparity()};
    report["runs"] = runs;

    std::vector<CellStats> cells;
    ProgressBar progress(int64_t(types.size() * distances.size()) * runs, "eval ranging");
    Stopwatch watch;
    for (size_t t = 0; t < types.size(); ++t) {
      for (double distance : distances) {
        std::vector<std::vector<RangeResult>> results(calibs.size());
        std::vector<double> truths;
        sim::PowerLineSceneOptions o = scene_options;
        o.obstacles = {{types[t], distance, 0}};
        const sim::PowerLineSceneRenderer renderer(o);  // ray cast once, fresh sensor noise per run
        for (int run = 0; run < runs; ++run) {
          const sim::PowerLineScene scene = renderer.Capture(std::uint64_t(run) * 7919 + 17);
          const sim::RenderedObstacle& obstacle = scene.obstacles.front();
          truths.push_back(obstacle.distance_m);
          const cv::Rect roi = GrowRoi(obstacle.box, scene.left.size());
          for (size_t c = 0; c < calibs.size(); ++c) {
            const RangingFrame frame =
                pipelines[c].Process(scene.left, scene.right, cv::Range(roi.y, roi.br().y));
            results[c].push_back(pipelines[c].RangeRois(frame, {roi}).front());
            if (diagnose) {
              PrintDiagnosis(type_names[t], calibs[c].first, run, scene, obstacle, roi,
                             pipelines[c], frame, results[c].back());
            }
          }
          progress.Advance();
        }
        for (size_t c = 0; c < calibs.size(); ++c) {
          cells.push_back(Summarise(calibs[c].first, type_names[t], distance, results[c], truths));
        }
      }
    }
    progress.Finish();

    std::string table = fmt::format(
        "| calibration | type | true m | runs | measured | mean m | abs err m | rel err % | mean "
        "abs rel % | std m | "
        "mean sigma m | within 2 sigma % |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    report["cells"] = nlohmann::json::array();
    for (const CellStats& c : cells) {
      table += fmt::format(
          "| {} | {} | {:.2f} | {} | {} | {:.4f} | {:+.4f} | {:+.2f} | {:.2f} | {:.4f} | {:.4f} | "
          "{:.0f} |\n",
          c.calibration, c.type, c.truth_m, c.runs, c.measured, c.mean_m, c.mean_m - c.truth_m,
          100.0 * c.relative_error(), 100.0 * c.mean_abs_relative, c.std_m, c.mean_sigma_m,
          c.measured ? 100.0 * c.covered / c.measured : 0.0);
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
      for (const auto& [reason, count] : c.failures) {
        std::fprintf(stderr, "%s %s %.2f m: %d run(s) without a measurement: %s\n",
                     c.calibration.c_str(), c.type.c_str(), c.truth_m, count, reason.c_str());
      }
    }
    std::ostream& out = TableStream(json_path);
    out << table;
    std::fprintf(stderr, "%zu scenes in %.1f s\n", types.size() * distances.size() * size_t(runs),
                 watch.ElapsedMs() / 1000.0);

    if (!middlebury_dir.empty()) {
      const MiddleburyCheck check = RunMiddleburyCheck(middlebury_dir, options);
      if (check.ran) {
        out << fmt::format(
            "\nMiddlebury 2014 Motorcycle (quarter), {}: depth Z = baseline*f/(d + doffs) from our "
            "disparity vs from "
            "the ground truth, non-occluded pixels: median relative error {:.2f} %, mean {:.2f} %, "
            "within 1 %: "
            "{:.1f} % of {} pixels (density {:.1f} %)\n",
            report["method"].get<std::string>(), 100.0 * check.median_relative_error,
            100.0 * check.mean_relative_error, 100.0 * check.within_1_percent, check.pixels,
            100.0 * check.density);
        report["middlebury_motorcycle"] = {{"median_relative_error", check.median_relative_error},
                                           {"mean_relative_error", check.mean_relative_error},
                                           {"within_1_percent", check.within_1_percent},
                                           {"pixels", check.pixels},
                                           {"density", check.density}};
      } else {
        out << "\nMiddlebury check skipped: " << check.reason << "\n";
        report["middlebury_motorcycle"] = {{"skipped", check.reason}};
      }
    }
    if (!markdown_path.empty()) WriteTextAtomic(markdown_path, table);
    if (!plot_path.empty()) {
      WriteTextAtomic(
          plot_path, MakeSvgPlot(cells, calibrations, type_names,
                                 std::ceil(*std::max_element(distances.begin(), distances.end()))));
    }
    if (!json_path.empty()) WriteJson(json_path, report);
  });
}

}  // namespace linesight::cli
