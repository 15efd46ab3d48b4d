// linesight eval calibration: the simulation study of the calibration methods against the
// Cramér-Rao bound.
#include <cstdio>
#include <filesystem>

#include <fmt/format.h>

#include "cli.h"
#include "commands.h"
#include "linesight/calib/simulation.h"
#include "linesight/core/atomic_file.h"
#include "linesight/core/error.h"
#include "linesight/core/progress.h"
#include "linesight/io/json_io.h"

namespace linesight::cli {

int RunEvalCalibration(int argc, char** argv) {
  CLI::App app{
      "Simulation study of stereo calibration: virtual 800x600 rig (f = 700 px, pp (400, 300), "
      "baseline "
      "120 mm, small distortion), random board poses, Gaussian corner noise; sweeps over noise and "
      "image "
      "count; every method on the same trials; errors vs the Cramér-Rao lower bound.",
      "eval calibration"};
  calib::CalibrationStudyOptions options;
  std::vector<std::string> method_names = {"zhang", "recon", "opencv"};
  std::vector<std::string> sweeps = {"noise", "images"};
  std::string json_path, csv_path, plots_dir;
  bool estimate_k3 = false;
  app.add_option("--trials", options.trials, "independent trials per point")->capture_default_str();
  app.add_option("--noise-levels", options.noise_levels_px, "sweep (a): corner noise σ in px")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--images", options.images, "sweep (a): images per trial")->capture_default_str();
  app.add_option("--image-counts", options.image_counts, "sweep (b): images per trial")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--noise", options.noise_px, "sweep (b): corner noise σ in px")
      ->capture_default_str();
  app.add_option("--sweeps", sweeps, "which sweeps to run: noise, images")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--methods", method_names, "methods: zhang, recon, opencv")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--seed", options.seed, "random seed")->capture_default_str();
  app.add_flag("--estimate-k3", estimate_k3,
               "estimate k3 too (default: k1 k2 p1 p2, k3 held at its true 0)");
  app.add_option("--recon-point-weight", options.calibration.recon_point_weight,
                 "recon: w_p in [0, 1]")
      ->capture_default_str();
  app.add_option("--recon-distance-weight", options.calibration.recon_distance_weight, "recon: w_d")
      ->capture_default_str();
  app.add_flag("--recon-board-bend,!--no-recon-board-bend", options.calibration.recon_board_bend,
               "recon: estimate the board's quadratic bend (the simulated board is flat)")
      ->capture_default_str();
  std::string recon_noise = "view";
  app.add_option("--recon-noise", recon_noise, "recon: corner-noise model: iid, camera or view")
      ->capture_default_str();
  app.add_option("--json", json_path, "JSON report (- for stdout)");
  app.add_option("--csv", csv_path, "CSV table");
  app.add_option("--plots", plots_dir, "write calibration_{noise,images}_{rms,mae}.svg here");
  return RunCommand(app, argc, argv, [&] {
    options.calibration.recon_noise = calib::ParseReconNoise(recon_noise);
    options.methods.clear();
    for (const std::string& name : method_names)
      options.methods.push_back(calib::ParseMethod(name));
    bool run_noise = false, run_images = false;
    for (const std::string& s : sweeps) {
      if (s == "noise") {
        run_noise = true;
      } else if (s == "images") {
        run_images = true;
      } else {
        throw UsageError(fmt::format("--sweeps '{}': expected noise and/or images", s));
      }
    }
    if (!run_noise) options.noise_levels_px.clear();
    if (!run_images) options.image_counts.clear();
    options.distortion.fix_k3 = !estimate_k3;
    options.Check();
    const int total =
        static_cast<int>(options.noise_levels_px.size() + options.image_counts.size()) *
        options.trials;
    ProgressBar progress(total, "eval calibration");
    const auto rows = calib::RunCalibrationStudy(options, [&](int, int) { progress.Advance(1); });
    progress.Finish();

    if (!csv_path.empty()) WriteTextAtomic(csv_path, calib::StudyCsv(rows));
    if (!json_path.empty()) WriteJson(json_path, calib::StudyJson(options, rows));
    if (!plots_dir.empty()) {
      std::filesystem::create_directories(plots_dir);
      for (const char* sweep : {"noise", "images"}) {
        if ((std::string(sweep) == "noise" && !run_noise) ||
            (std::string(sweep) == "images" && !run_images)) {
          continue;
        }
        for (bool rms : {true, false}) {
          WriteTextAtomic(std::filesystem::path(plots_dir) /
                              fmt::format("calibration_{}_{}.svg", sweep, rms ? "rms" : "mae"),
                          calib::StudySvg(rows, sweep, rms));
        }
      }
    }
    std::FILE* out = json_path == "-" ? stderr : stdout;
    std::fprintf(
        out, "RMS error (mean absolute error) over %d trials; fx fy u0 v0 in px, tx ty tz in mm\n",
        options.trials);
    std::fprintf(out, "%-6s %5s %4s %-6s", "sweep", "sigma", "imgs", "method");
    for (const char* name : calib::kStudyParameterNames) std::fprintf(out, " %17s", name);
    std::fprintf(out, " %8s %4s\n", "reproj", "fail");
    for (const calib::StudyRow& r : rows) {
      std::fprintf(out, "%-6s %5.2f %4d %-6s", r.sweep.c_str(), r.noise_px, r.images,
                   r.method.c_str());
      for (int i = 0; i < calib::kStudyParameterCount; ++i) {
        std::fprintf(out, " %8.4f (%6.4f)", r.rms_error[i], r.mean_abs_error[i]);
      }
      std::fprintf(out, " %8.4f %4d\n", r.reprojection_rms_px, r.failures);
    }
  });
}

}  // namespace linesight::cli
