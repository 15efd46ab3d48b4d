// linesight disparity: dense disparity of a stereo pair.
#include <filesystem>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "cli.h"
#include "commands.h"
#include "linesight/core/error.h"
#include "linesight/core/timer.h"
#include "linesight/io/disparity_io.h"
#include "linesight/io/image_io.h"
#include "linesight/io/json_io.h"
#include "linesight/io/pfm.h"
#include "linesight/stereo/matcher.h"

namespace linesight::cli {

int RunDisparity(int argc, char** argv) {
  CLI::App app{"Dense disparity of a rectified stereo pair (left view, float px, +inf = invalid).",
               "disparity"};
  std::string left_path, right_path, out_path, color_path, kitti_path, json_path;
  std::string method = DefaultMatcherName();
  int min_disp = 0, num_disp = 64, threads = 0;
  std::vector<std::string> raw_params;
  app.add_option("--left", left_path, "left image (rectified)")->required();
  app.add_option("--right", right_path, "right image (rectified)")->required();
  app.add_option("--method", method, fmt::format("matcher: {}", fmt::join(MatcherNames(), ", ")))
      ->capture_default_str();
  app.add_option("--min-disp", min_disp, "smallest disparity searched (px)")->capture_default_str();
  app.add_option("--num-disp", num_disp, "number of disparities searched (any value >= 1)")
      ->capture_default_str();
  app.add_option("--threads", threads, "worker threads (0 = all cores)")->capture_default_str();
  AddParamOption(app, &raw_params);
  app.footer(MatcherHelp());
  app.add_option("--out", out_path, "disparity output, PFM (float px, inf = invalid)")->required();
  app.add_option("--color", color_path, "colour-mapped disparity PNG for people");
  app.add_option("--kitti", kitti_path, "KITTI 16-bit PNG (value = round(d*256), 0 = invalid)");
  app.add_option("--json", json_path, "machine-readable report (- for stdout)");
  return RunCommand(app, argc, argv, [&] {
    MatcherOptions options;
    options.min_disparity = min_disp;
    options.num_disparities = num_disp;
    options.threads = threads;
    options.params = ParseParams(raw_params);
    auto matcher = CreateMatcher(method, options);  // validate before reading anything
    const cv::Mat left = ReadImage(left_path, ImageColor::kColor);
    const cv::Mat right = ReadImage(right_path, ImageColor::kColor);
    CheckSameSize(left, left_path, right, right_path);

    Stopwatch watch;
    const cv::Mat disparity = matcher->Compute(left, right).disparity;
    const double ms = watch.ElapsedMs();

    WritePfm(out_path, disparity);
    if (!color_path.empty()) {
      WriteImage(color_path,
                 ColorizeDisparityWithLegend(disparity, static_cast<float>(min_disp),
                                             static_cast<float>(min_disp + num_disp - 1)));
    }
    if (!kitti_path.empty()) WriteKittiDisparity(kitti_path, disparity);
    const double density = DisparityDensity(disparity);
    if (!json_path.empty()) {
      WriteJson(json_path, {{"left", left_path},
                            {"right", right_path},
                            {"out", out_path},
                            {"width", left.cols},
                            {"height", left.rows},
                            {"ms", ms},
                            {"mde_per_s", MdePerSecond(left.cols, left.rows, num_disp, ms)},
                            {"density", density},
                            {"settings", matcher->Settings()}});
    }
    std::fprintf(stderr, "%s: %dx%d, %d disparities, %.1f ms, density %.1f %%\n", method.c_str(),
                 left.cols, left.rows, num_disp, ms, density);
  });
}

}  // namespace linesight::cli
