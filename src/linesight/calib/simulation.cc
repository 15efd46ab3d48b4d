#include "linesight/calib/simulation.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>

#include <Eigen/Geometry>

#include "linesight/calib/calibration_report.h"
#include "linesight/core/error.h"

namespace linesight::calib {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

bool BoardInside(const CameraIntrinsics& camera, const Pose& camera_from_board,
                 const BoardGeometry& board, cv::Size size, double margin) {
  for (const Eigen::Vector3d& p : board.points) {
    const Eigen::Vector3d c = camera_from_board.Apply(p);
    double pixel[2];
    if (!Project(camera.params.data(), c.data(), pixel)) return false;
    if (pixel[0] < margin || pixel[1] < margin || pixel[0] > size.width - 1 - margin ||
        pixel[1] > size.height - 1 - margin) {
      return false;
    }
  }
  return true;
}

std::string Format(double v) { return fmt::format("{:.6g}", v); }

}  // namespace

SimulationRig DefaultSimulationRig() {
  SimulationRig rig;
  rig.image_size = cv::Size(800, 600);
  rig.left.params = {700, 700, 400, 300, -0.05, 0.02, 3e-4, -2e-4, 0, 0, 0, 0};
  rig.right.params = rig.left.params;
  const Eigen::Matrix3d rotation =
      Eigen::AngleAxisd(0.5 * kDegToRad, Eigen::Vector3d(0.2, 1.0, 0.1).normalized())
          .toRotationMatrix();
  rig.right_from_left =
      Pose::FromRotationTranslation(rotation, Eigen::Vector3d(-0.12, 0.0005, -0.001));
  PatternSpec spec;
  spec.type = PatternType::kChessboard;
  spec.cols = 9;
  spec.rows = 6;
  spec.square_m = 0.04;
  rig.board = MakeBoardGeometry(spec);
  return rig;
}

void BoardPoseOptions::Check() const {
  CheckOption(min_distance_m > 0, "BoardPoseOptions.min_distance_m", min_distance_m, "must be > 0");
  CheckOption(max_distance_m >= min_distance_m, "BoardPoseOptions.max_distance_m", max_distance_m,
              "must be >= min_distance_m");
  CheckOption(max_tilt_deg >= 0 && max_tilt_deg < 80, "BoardPoseOptions.max_tilt_deg", max_tilt_deg,
              "must be in [0, 80)");
  CheckOption(max_roll_deg >= 0 && max_roll_deg <= 180, "BoardPoseOptions.max_roll_deg",
              max_roll_deg, "must be in [0, 180]");
  CheckOption(margin_px >= 0, "BoardPoseOptions.margin_px", margin_px, "must be >= 0");
}

std::vector<Pose> RandomBoardPoses(const SimulationRig& rig, int count,
                                   const BoardPoseOptions& options, std::mt19937_64& rng) {
  options.Check();
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const auto& p : rig.board.points) centre += p;
  centre /= static_cast<double>(rig.board.points.size());
  std::vector<Pose> poses;
  int attempts = 0;
  while (static_cast<int>(poses.size()) < count) {
    LS_CHECK_MSG(++attempts < 1000000, "cannot place the board inside both images");
    const double distance =
        options.min_distance_m + unit(rng) * (options.max_distance_m - options.min_distance_m);
    const double u = unit(rng) * rig.image_size.width, v = unit(rng) * rig.image_size.height;
    const Eigen::Vector3d target((u - rig.left.cx()) / rig.left.fx() * distance,
                                 (v - rig.left.cy()) / rig.left.fy() * distance, distance);
    const double axis_angle = unit(rng) * 2 * M_PI;
    const double tilt = unit(rng) * options.max_tilt_deg * kDegToRad;
    const double roll = (2 * unit(rng) - 1) * options.max_roll_deg * kDegToRad;
    const Eigen::Matrix3d rotation =
        (Eigen::AngleAxisd(tilt, Eigen::Vector3d(std::cos(axis_angle), std::sin(axis_angle), 0)) *
         Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()))
            .toRotationMatrix();
    const Pose pose = Pose::FromRotationTranslation(rotation, target - rotation * centre);
    if (!BoardInside(rig.left, pose, rig.board, rig.image_size, options.margin_px)) continue;
    if (!BoardInside(rig.right, rig.right_from_left * pose, rig.board, rig.image_size,
                     options.margin_px)) {
      continue;
    }
    poses.push_back(pose);
  }
  return poses;
}

StereoObservations SynthesizeObservations(const SimulationRig& rig,
                                          const std::vector<Pose>& left_from_board, double noise_px,
                                          std::mt19937_64& rng) {
  std::normal_distribution<double> noise(0.0, 1.0);
  StereoObservations obs;
  obs.board = rig.board;
  obs.image_size = rig.image_size;
  for (const Pose& pose : left_from_board) {
    const Pose right_pose = rig.right_from_left * pose;
    ViewObservations left, right;
    for (size_t id = 0; id < rig.board.points.size(); ++id) {
      for (int side = 0; side < 2; ++side) {
        const Eigen::Vector3d c = (side == 0 ? pose : right_pose).Apply(rig.board.points[id]);
        double pixel[2];
        LS_CHECK(Project((side == 0 ? rig.left : rig.right).params.data(), c.data(), pixel));
        ViewObservations& view = side == 0 ? left : right;
        view.ids.push_back(static_cast<int>(id));
        view.pixels.emplace_back(pixel[0] + noise_px * noise(rng),
                                 pixel[1] + noise_px * noise(rng));
      }
    }
    obs.left.push_back(std::move(left));
    obs.right.push_back(std::move(right));
  }
  return obs;
}

std::array<double, kStudyParameterCount> StudyParameters(const StereoCalibrationResult& e) {
  return {e.left.fx(),
          e.left.fy(),
          e.left.cx(),
          e.left.cy(),
          1000 * e.right_from_left.params[3],
          1000 * e.right_from_left.params[4],
          1000 * e.right_from_left.params[5]};
}

std::array<double, kStudyParameterCount> CramerRaoStddev(const SimulationRig& rig,
                                                         const std::vector<Pose>& left_from_board,
                                                         double noise_px,
                                                         const DistortionModel& model) {
  std::mt19937_64 unused_rng(0);
  const StereoObservations exact = SynthesizeObservations(rig, left_from_board, 0.0, unused_rng);
  StereoCalibrationResult truth;
  truth.distortion = model;
  truth.left = rig.left;
  truth.right = rig.right;
  truth.right_from_left = rig.right_from_left;
  truth.left_from_board.assign(left_from_board.begin(), left_from_board.end());
  truth.right_only_from_board.assign(left_from_board.size(), std::nullopt);
  const ReprojectionCovariance covariance = ComputeReprojectionCovariance(exact, truth);
  LS_CHECK_MSG(covariance.valid, "the Fisher information of the simulated rig is singular");
  const double s2 = noise_px * noise_px;
  return {std::sqrt(s2 * covariance.left(kFx, kFx)),
          std::sqrt(s2 * covariance.left(kFy, kFy)),
          std::sqrt(s2 * covariance.left(kCx, kCx)),
          std::sqrt(s2 * covariance.left(kCy, kCy)),
          1000 * std::sqrt(s2 * covariance.right_from_left(3, 3)),
          1000 * std::sqrt(s2 * covariance.right_from_left(4, 4)),
          1000 * std::sqrt(s2 * covariance.right_from_left(5, 5))};
}

void CalibrationStudyOptions::Check() const {
  CheckOption(trials >= 1, "CalibrationStudyOptions.trials", trials, "must be >= 1");
  CheckOption(images >= 3, "CalibrationStudyOptions.images", images, "must be >= 3");
  CheckOption(noise_px >= 0, "CalibrationStudyOptions.noise_px", noise_px, "must be >= 0");
  CheckOption(!methods.empty(), "CalibrationStudyOptions.methods", methods.size(),
              "must not be empty");
  for (double n : noise_levels_px)
    CheckOption(n >= 0, "CalibrationStudyOptions.noise_levels_px", n, "must be >= 0");
  for (int c : image_counts)
    CheckOption(c >= 3, "CalibrationStudyOptions.image_counts", c, "must be >= 3");
  poses.Check();
  calibration.Check();
}

std::vector<StudyRow> RunCalibrationStudy(const CalibrationStudyOptions& options,
                                          const std::function<void(int, int)>& progress) {
  options.Check();
  const SimulationRig rig = DefaultSimulationRig();
  const std::array<double, kStudyParameterCount> truth = [&] {
    StereoCalibrationResult t;
    t.left = rig.left;
    t.right_from_left = rig.right_from_left;
    return StudyParameters(t);
  }();
  struct Point {
    std::string sweep;
    double noise;
    int images;
  };
  std::vector<Point> points;
  for (double n : options.noise_levels_px) points.push_back({"noise", n, options.images});
  for (int c : options.image_counts) points.push_back({"images", options.noise_px, c});
  const int total = static_cast<int>(points.size()) * options.trials;
  int done = 0;
  std::vector<StudyRow> rows;
  for (size_t p = 0; p < points.size(); ++p) {
    const Point& point = points[p];
    struct Accumulator {
      int trials = 0, failures = 0;
      std::array<double, kStudyParameterCount> abs_sum{}, sq_sum{};
      double reprojection_sum = 0;
    };
    std::map<CalibrationMethod, Accumulator> by_method;
    std::array<double, kStudyParameterCount> bound_variance_sum{};
    double bound_dof_sum = 0;
    for (int t = 0; t < options.trials; ++t) {
      std::mt19937_64 rng(options.seed + 1000003ULL * p + 7919ULL * static_cast<uint64_t>(t));
      const std::vector<Pose> poses = RandomBoardPoses(rig, point.images, options.poses, rng);
      const StereoObservations obs = SynthesizeObservations(rig, poses, point.noise, rng);
      const auto bound = CramerRaoStddev(rig, poses, point.noise, options.distortion);
      for (int i = 0; i < kStudyParameterCount; ++i) bound_variance_sum[i] += bound[i] * bound[i];
      {
        // Expected per-point residual RMS of the maximum-likelihood fit (same definition as
        // StereoRms): σ·√2·sqrt(1 − n/m).
        const int m = 2 * 2 * static_cast<int>(rig.board.points.size()) * point.images;
        const int free_intrinsics =
            2 * (kNumIntrinsics - static_cast<int>(options.distortion.FixedIndices().size()));
        const int n = free_intrinsics + kPoseSize + kPoseSize * point.images;
        bound_dof_sum += point.noise * std::sqrt(2.0) *
                         std::sqrt(std::max(0.0, 1.0 - static_cast<double>(n) / m));
      }
      for (CalibrationMethod method : options.methods) {
        StereoCalibrationOptions calibration = options.calibration;
        calibration.method = method;
        calibration.distortion = options.distortion;
        Accumulator& acc = by_method[method];
        try {
          const StereoCalibrationResult result = CalibrateStereo(obs, calibration);
          const auto estimate = StudyParameters(result);
          for (int i = 0; i < kStudyParameterCount; ++i) {
            const double error = estimate[i] - truth[i];
            acc.abs_sum[i] += std::abs(error);
            acc.sq_sum[i] += error * error;
          }
          acc.reprojection_sum += StereoRms(obs, result);
          ++acc.trials;
        } catch (const InputError&) {
          ++acc.failures;
        }
      }
      if (progress) progress(++done, total);
    }
    for (CalibrationMethod method : options.methods) {
      const Accumulator& acc = by_method[method];
      StudyRow row{point.sweep,        point.noise, point.images,
                   MethodName(method), acc.trials,  acc.failures};
      for (int i = 0; i < kStudyParameterCount && acc.trials; ++i) {
        row.mean_abs_error[i] = acc.abs_sum[i] / acc.trials;
        row.rms_error[i] = std::sqrt(acc.sq_sum[i] / acc.trials);
      }
      row.reprojection_rms_px = acc.trials ? acc.reprojection_sum / acc.trials : std::nan("");
      rows.push_back(row);
    }
    StudyRow bound{point.sweep, point.noise, point.images, "crlb", options.trials, 0};
    for (int i = 0; i < kStudyParameterCount; ++i) {
      bound.rms_error[i] = std::sqrt(bound_variance_sum[i] / options.trials);
      bound.mean_abs_error[i] = std::sqrt(2.0 / M_PI) * bound.rms_error[i];  // E|e| of N(0, bound²)
    }
    bound.reprojection_rms_px = bound_dof_sum / options.trials;
    rows.push_back(bound);
  }
  return rows;
}

std::string StudyCsv(const std::vector<StudyRow>& rows) {
  std::ostringstream csv;
  csv << "sweep,noise_px,images,method,trials,failures";
  for (const char* name : kStudyParameterNames) csv << ",mae_" << name;
  for (const char* name : kStudyParameterNames) csv << ",rms_" << name;
  csv << ",reprojection_rms_px\n";
  for (const StudyRow& r : rows) {
    csv << r.sweep << "," << Format(r.noise_px) << "," << r.images << "," << r.method << ","
        << r.trials << "," << r.failures;
    for (double v : r.mean_abs_error) csv << "," << Format(v);
    for (double v : r.rms_error) csv << "," << Format(v);
    csv << "," << Format(r.reprojection_rms_px) << "\n";
  }
  return csv.str();
}

nlohmann::json StudyJson(const CalibrationStudyOptions& options,
                         const std::vector<StudyRow>& rows) {
  const SimulationRig rig = DefaultSimulationRig();
  nlohmann::json j;
  j["rig"] = {{"image_size", {rig.image_size.width, rig.image_size.height}},
              {"left_intrinsics", rig.left.params},
              {"right_intrinsics", rig.right.params},
              {"right_from_left", rig.right_from_left.params},
              {"board", "chessboard 9x6 inner corners, 40 mm"}};
  j["settings"] = {{"trials", options.trials},
                   {"images", options.images},
                   {"noise_px", options.noise_px},
                   {"noise_levels_px", options.noise_levels_px},
                   {"image_counts", options.image_counts},
                   {"seed", options.seed},
                   {"estimate_k3", !options.distortion.fix_k3},
                   {"units", "fx fy u0 v0 in px, tx ty tz in mm"}};
  nlohmann::json out = nlohmann::json::array();
  for (const StudyRow& r : rows) {
    nlohmann::json item = {{"sweep", r.sweep},
                           {"noise_px", r.noise_px},
                           {"images", r.images},
                           {"method", r.method},
                           {"trials", r.trials},
                           {"failures", r.failures},
                           {"reprojection_rms_px", r.reprojection_rms_px}};
    for (int i = 0; i < kStudyParameterCount; ++i) {
      item["mean_abs_error"][kStudyParameterNames[i]] = r.mean_abs_error[i];
      item["rms_error"][kStudyParameterNames[i]] = r.rms_error[i];
    }
    out.push_back(item);
  }
  j["rows"] = out;
  return j;
}

std::string StudySvg(const std::vector<StudyRow>& rows, const std::string& sweep, bool rms) {
  std::vector<std::string> methods;
  for (const StudyRow& r : rows) {
    if (r.sweep == sweep && std::find(methods.begin(), methods.end(), r.method) == methods.end()) {
      methods.push_back(r.method);
    }
  }
  const std::map<std::string, std::string> colours = {
      {"zhang", "#1f77b4"}, {"recon", "#d62728"}, {"opencv", "#2ca02c"}, {"crlb", "#000000"}};
  const int panels = kStudyParameterCount + 1, columns = 4;
  const double panel_w = 300, panel_h = 230, pad_l = 55, pad_b = 35, pad_t = 25, pad_r = 10;
  const int panel_rows = (panels + columns - 1) / columns;
  std::ostringstream svg;
  svg << fmt::format(
             R"(<svg xmlns="http://www.w3.org/2000/svg" width="{}" height="{}" font-family="sans-serif" font-size="10">)",
             columns * panel_w, panel_rows * panel_h + 30)
      << "\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  svg << fmt::format(
             R"(<text x="10" y="18" font-size="13">{} error vs {} (one line per method; black dashed = Cramér-Rao bound)</text>)",
             rms ? "RMS" : "mean absolute",
             sweep == "noise" ? "corner noise σ (px)" : "number of images")
      << "\n";
  for (int panel = 0; panel < panels; ++panel) {
    const double ox = (panel % columns) * panel_w, oy = 30 + (panel / columns) * panel_h;
    const std::string title =
        panel < kStudyParameterCount
            ? std::string(kStudyParameterNames[panel]) + (panel < 4 ? " (px)" : " (mm)")
            : "reprojection RMS (px)";
    const auto value = [&](const StudyRow& r) {
      if (panel == kStudyParameterCount) return r.reprojection_rms_px;
      return rms ? r.rms_error[panel] : r.mean_abs_error[panel];
    };
    double x_min = 1e300, x_max = -1e300, y_max = 1e-12;
    for (const StudyRow& r : rows) {
      if (r.sweep != sweep) continue;
      const double x = sweep == "noise" ? r.noise_px : r.images;
      x_min = std::min(x_min, x);
      x_max = std::max(x_max, x);
      if (std::isfinite(value(r))) y_max = std::max(y_max, value(r));
    }
    if (x_max <= x_min) x_max = x_min + 1;
    y_max *= 1.1;
    const double plot_w = panel_w - pad_l - pad_r, plot_h = panel_h - pad_t - pad_b;
    const auto sx = [&](double x) { return ox + pad_l + (x - x_min) / (x_max - x_min) * plot_w; };
    const auto sy = [&](double y) { return oy + pad_t + plot_h - y / y_max * plot_h; };
    svg << fmt::format(R"(<text x="{}" y="{}" font-size="12">{}</text>)", ox + pad_l, oy + 15,
                       title)
        << "\n";
    svg << fmt::format(R"(<rect x="{}" y="{}" width="{}" height="{}" fill="none" stroke="#888"/>)",
                       ox + pad_l, oy + pad_t, plot_w, plot_h)
        << "\n";
    for (int t = 0; t <= 4; ++t) {
      const double y = y_max * t / 4;
      svg << fmt::format(R"(<text x="{}" y="{}" text-anchor="end">{:.3g}</text>)", ox + pad_l - 3,
                         sy(y) + 3, y)
          << "\n";
      const double x = x_min + (x_max - x_min) * t / 4;
      svg << fmt::format(R"(<text x="{}" y="{}" text-anchor="middle">{:.3g}</text>)", sx(x),
                         oy + pad_t + plot_h + 13, x)
          << "\n";
    }
    for (const std::string& method : methods) {
      std::string path;
      for (const StudyRow& r : rows) {
        if (r.sweep != sweep || r.method != method || !std::isfinite(value(r))) continue;
        const double x = sweep == "noise" ? r.noise_px : r.images;
        path += fmt::format("{}{:.1f},{:.1f} ", path.empty() ? "" : "", sx(x), sy(value(r)));
      }
      const std::string colour = colours.count(method) ? colours.at(method) : "#9467bd";
      svg << fmt::format(R"(<polyline points="{}" fill="none" stroke="{}" stroke-width="1.5"{}/>)",
                         path, colour, method == "crlb" ? R"( stroke-dasharray="5,3")" : "")
          << "\n";
    }
  }
  // Legend.
  double lx = columns * panel_w - 330;
  for (const std::string& method : methods) {
    const std::string colour = colours.count(method) ? colours.at(method) : "#9467bd";
    svg << fmt::format(
               R"(<line x1="{}" y1="14" x2="{}" y2="14" stroke="{}" stroke-width="2"/><text x="{}" y="18">{}</text>)",
               lx, lx + 20, colour, lx + 24, method)
        << "\n";
    lx += 80;
  }
  svg << "</svg>\n";
  return svg.str();
}

}  // namespace linesight::calib
