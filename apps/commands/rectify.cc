// linesight rectify: Bouguet rectification of a raw stereo pair with a calibration file.
#include <filesystem>

#include <fmt/format.h>

#include "cli.h"
#include "commands.h"
#include "linesight/core/error.h"
#include "linesight/io/image_io.h"
#include "linesight/io/json_io.h"
#include "linesight/io/stereo_calibration.h"
#include "linesight/rectify/rectifier.h"

namespace linesight::cli {

int RunRectify(int argc, char** argv) {
  CLI::App app{
      "Rectify a raw stereo pair (Bouguet: cv::stereoRectify + initUndistortRectifyMap + remap).",
      "rectify"};
  std::string calib_path, left_path, right_path, out_dir, calib_out_path;
  RectifyOptions options;
  app.add_option("--calib", calib_path,
                 "stereo calibration (OpenCV YAML: M1 D1 M2 D2 R T ... P1 P2 Q)")
      ->required();
  app.add_option("--left", left_path, "raw left image")->required();
  app.add_option("--right", right_path, "raw right image")->required();
  app.add_option("--out", out_dir,
                 "output folder (created): left_rect.png, right_rect.png, epipolar.png")
      ->required();
  CLI::Option* recompute = app.add_flag(
      "--recompute", options.recompute,
      "recompute R1 R2 P1 P2 Q with cv::stereoRectify instead of using those in the file");
  app.add_option(
         "--alpha", options.alpha,
         "with --recompute: 0 = only valid pixels, 1 = all source pixels, -1 = OpenCV default")
      ->capture_default_str()
      ->needs(recompute);
  app.add_option("--calib-out", calib_out_path,
                 "with --recompute: write the recomputed calibration here (YAML)")
      ->needs(recompute);
  return RunCommand(app, argc, argv, [&] {
    options.Check();
    const StereoCalibration calib = ReadStereoCalibration(calib_path);
    const cv::Mat left = ReadImage(left_path, ImageColor::kUnchanged);
    const cv::Mat right = ReadImage(right_path, ImageColor::kUnchanged);
    CheckSameSize(left, left_path, right, right_path);
    CheckCalibrationMatchesImage(calib, left.size(), calib_path);
    const Rectifier rectifier(calib, options);
    cv::Mat left_rect, right_rect;
    rectifier.Rectify(left, right, &left_rect, &right_rect);
    std::filesystem::create_directories(out_dir);
    const std::filesystem::path dir(out_dir);
    WriteImage(dir / "left_rect.png", left_rect);
    WriteImage(dir / "right_rect.png", right_rect);
    WriteImage(dir / "epipolar.png", DrawEpipolarCheck(left_rect, right_rect));
    if (!calib_out_path.empty()) WriteStereoCalibration(calib_out_path, rectifier.calibration());
    const cv::Rect roi = rectifier.rectification().CommonValidRoi();
    std::fprintf(stderr,
                 "rectified %dx%d pair -> %s (valid region %d,%d,%d,%d; f = %.2f px, B = %.4f m)\n",
                 left.cols, left.rows, out_dir.c_str(), roi.x, roi.y, roi.width, roi.height,
                 rectifier.calibration().P1.at<double>(0, 0), rectifier.calibration().Baseline());
  });
}

}  // namespace linesight::cli
