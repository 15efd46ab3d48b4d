// linesight calibrate: stereo calibration from image pairs of a board (zhang | recon | opencv).
#include <cmath>
#include <cstdio>
#include <filesystem>

#include <fmt/format.h>

#include "cli.h"
#include "commands.h"
#include "linesight/calib/calibration_report.h"
#include "linesight/calib/pattern.h"
#include "linesight/calib/stereo_calibrator.h"
#include "linesight/core/atomic_file.h"
#include "linesight/core/error.h"
#include "linesight/io/image_io.h"
#include "linesight/io/json_io.h"
#include "linesight/io/stereo_calibration.h"

namespace linesight::cli {
namespace {

void CheckOutputFolder(const std::filesystem::path& file, const char* option) {
  const std::filesystem::path parent = file.parent_path();
  if (!parent.empty() && !std::filesystem::is_directory(parent)) {
    throw InputError(
        fmt::format("{} {}: folder '{}' does not exist", option, file.string(), parent.string()));
  }
}

}  // namespace

int RunCalibrate(int argc, char** argv) {
  CLI::App app{
      "Stereo calibration from image pairs of a calibration board. Writes stereo.yml (OpenCV YAML "
      "with "
      "the rectification), optionally ROS camera_info files, a JSON report and plots.",
      "calibrate"};
  std::string left_glob, right_glob, pattern_text, method_name = "zhang", out_path, ros_dir,
                                                   json_path, plots_dir;
  std::string detector = "sb";
  calib::StereoCalibrationOptions options;
  app.add_option("--left", left_glob, "left images (glob, quote it: 'left*.png'); sorted by name")
      ->required();
  app.add_option("--right", right_glob, "right images (glob); paired with --left in sorted order")
      ->required();
  app.add_option("--pattern", pattern_text,
                 "chessboard:COLSxROWS:SQUARE_M (inner corners), "
                 "charuco:COLSxROWS:SQUARE_M:MARKER_M[:DICT] "
                 "(squares), circles:COLSxROWS:SPACING_M or acircles:COLSxROWS:SPACING_M")
      ->required();
  app.add_option("--method", method_name,
                 "zhang (ours), recon (ours, reconstruction error) or opencv")
      ->capture_default_str();
  app.add_option("--out", out_path, "stereo calibration YAML to write")->required();
  app.add_option("--ros-dir", ros_dir,
                 "also write ROS camera_info YAML (left.yaml, right.yaml) here");
  app.add_option("--json", json_path, "JSON report (- for stdout)");
  app.add_option("--plots", plots_dir, "write coverage.png and per_view_rms.svg here");
  app.add_option("--detector", detector,
                 "chessboard detector: sb (cv::findChessboardCornersSB) or classic "
                 "(cv::findChessboardCorners + cornerSubPix)")
      ->capture_default_str();
  app.add_flag("--rational", options.distortion.rational,
               "also estimate k4 k5 k6 (rational model)");
  app.add_flag("--fix-k3", options.distortion.fix_k3, "hold k3 = 0");
  app.add_flag("--zero-tangent", options.distortion.zero_tangential, "hold p1 = p2 = 0");
  app.add_option(
         "--recon-point-weight", options.recon_point_weight,
         "recon: share w_p² (w_p in [0, 1]) of each stereo corner's information taken through its "
         "whitened 3D reconstruction error")
      ->capture_default_str();
  app.add_option("--recon-distance-weight", options.recon_distance_weight,
                 "recon: weight w_d of the adjacent-distance term")
      ->capture_default_str();
  app.add_flag(
         "--recon-board-bend,!--no-recon-board-bend", options.recon_board_bend,
         "recon: estimate the board's quadratic out-of-plane bend instead of assuming it flat")
      ->capture_default_str();
  std::string recon_noise = "view";
  app.add_option(
         "--recon-noise", recon_noise,
         "recon: corner-noise model of the whitening: iid, camera (one level per camera) or "
         "view (one per camera and view), levels estimated from the residuals")
      ->capture_default_str();
  app.add_option("--min-views", options.min_views, "fewest views per camera and pair views (>= 3)")
      ->capture_default_str();
  return RunCommand(app, argc, argv, [&] {
    // Everything that can fail on the input is checked before anything is written.
    const calib::PatternSpec spec = calib::ParsePatternSpec(pattern_text);
    options.method = calib::ParseMethod(method_name);
    options.recon_noise = calib::ParseReconNoise(recon_noise);
    if (detector != "sb" && detector != "classic") {
      throw UsageError(fmt::format("--detector '{}': expected sb or classic", detector));
    }
    options.Check();
    CheckOutputFolder(out_path, "--out");
    if (!json_path.empty() && json_path != "-") CheckOutputFolder(json_path, "--json");
    calib::DetectionOptions detection_options;
    detection_options.sector_based = detector == "sb";
    const auto left_paths = ExpandGlob(left_glob);
    const auto right_paths = ExpandGlob(right_glob);
    const calib::StereoDetections detections =
        calib::DetectStereoPairs(left_paths, right_paths, spec, detection_options);
    for (const calib::PairDetection& pair : detections.pairs) {
      const auto status = [](const calib::Detection& d) {
        return d.found ? std::string("found") : d.reason;
      };
      std::fprintf(stderr, "%s: %s | %s: %s\n", pair.left_path.filename().c_str(),
                   status(pair.left).c_str(), pair.right_path.filename().c_str(),
                   status(pair.right).c_str());
    }
    const calib::StereoObservations observations =
        calib::ObservationsFromDetections(detections, calib::MakeBoardGeometry(spec));
    const calib::StereoCalibrationResult result = calib::CalibrateStereo(observations, options);
    const calib::CalibrationReport report = calib::EvaluateCalibration(observations, result);
    const nlohmann::json json = calib::ReportToJson(detections, result, report);

    WriteStereoCalibration(out_path, report.calibration);
    if (!ros_dir.empty()) {
      std::filesystem::create_directories(ros_dir);
      const StereoCalibration& c = report.calibration;
      WriteTextAtomic(std::filesystem::path(ros_dir) / "left.yaml",
                      calib::RosCameraInfoYaml("left", c.image_size, c.M1, c.D1, c.R1, c.P1));
      WriteTextAtomic(std::filesystem::path(ros_dir) / "right.yaml",
                      calib::RosCameraInfoYaml("right", c.image_size, c.M2, c.D2, c.R2, c.P2));
    }
    if (!plots_dir.empty()) {
      std::filesystem::create_directories(plots_dir);
      WriteImage(std::filesystem::path(plots_dir) / "coverage.png",
                 calib::CoverageImage(observations));
      WriteTextAtomic(std::filesystem::path(plots_dir) / "per_view_rms.svg",
                      calib::PerViewRmsSvg(report));
    }
    if (!json_path.empty()) WriteJson(json_path, json);

    std::FILE* out = json_path == "-" ? stderr : stdout;
    std::fprintf(out, "method %s: %d pairs, board found in %d left / %d right / %d both\n",
                 calib::MethodName(result.method).c_str(),
                 static_cast<int>(detections.pairs.size()), detections.LeftCount(),
                 detections.RightCount(), detections.BothCount());
    for (int side = 0; side < 2; ++side) {
      const calib::CameraIntrinsics& cam = side == 0 ? result.left : result.right;
      const auto& sd = side == 0 ? report.left_stddev : report.right_stddev;
      std::fprintf(
          out, "%-5s fx %.3f ± %.3f  fy %.3f ± %.3f  cx %.3f ± %.3f  cy %.3f ± %.3f  RMS %.4f px\n",
          side == 0 ? "left" : "right", cam.fx(), sd[calib::kFx], cam.fy(), sd[calib::kFy],
          cam.cx(), sd[calib::kCx], cam.cy(), sd[calib::kCy],
          side == 0 ? report.left_rms_px : report.right_rms_px);
    }
    const Eigen::Vector3d t = result.right_from_left.Translation();
    std::fprintf(out,
                 "right_from_left T = (%.6f, %.6f, %.6f) ± (%.6f, %.6f, %.6f), baseline %.6f\n",
                 t.x(), t.y(), t.z(), report.right_from_left_stddev[3],
                 report.right_from_left_stddev[4], report.right_from_left_stddev[5], t.norm());
    std::fprintf(out,
                 "stereo RMS %.4f px, epipolar |dy| after rectification %.4f px, reconstruction "
                 "error %.3f %% "
                 "of the square (%.4f mm)\n",
                 report.stereo_rms_px, report.epipolar_mean_abs_dy_px,
                 report.reconstruction_percent, 1000 * report.reconstruction_rmse_m);
    if (result.board_bend != calib::BoardBend{}) {
      std::fprintf(out, "board bend (u², v², uv at the grid corners) %.6f, %.6f, %.6f\n",
                   result.board_bend[0], result.board_bend[1], result.board_bend[2]);
    }
    std::fprintf(out, "wrote %s\n", out_path.c_str());
  });
}

}  // namespace linesight::cli
