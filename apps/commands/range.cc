// linesight range: distance +- sigma to obstacles in user ROIs or found automatically.
#include <filesystem>
#include <iostream>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "cli.h"
#include "commands.h"
#include "linesight/core/error.h"
#include "linesight/core/timer.h"
#include "linesight/io/image_io.h"
#include "linesight/io/json_io.h"
#include "linesight/io/pfm.h"
#include "linesight/io/stereo_calibration.h"
#include "linesight/ranging/pipeline.h"
#include "linesight/ranging/ranging_settings.h"

namespace linesight::cli {

int RunRange(int argc, char** argv) {
  CLI::App app{
      "Distance to obstacles: nearest surface along the optical axis, with a 1-sigma uncertainty.",
      "range"};
  std::string calib_path, left_path, right_path, json_path, disparity_out;
  std::vector<std::string> roi_texts, raw_params, ranging_settings;
  bool automatic = false;
  RangingPipelineOptions options;
  app.add_option("--calib", calib_path, "stereo calibration (OpenCV YAML)")->required();
  app.add_option("--left", left_path, "left image (raw unless --rectified)")->required();
  app.add_option("--right", right_path, "right image (raw unless --rectified)")->required();
  app.add_option("--roi", roi_texts, "region x,y,w,h in rectified left pixels (repeatable)");
  app.add_flag("--auto", automatic, "find the obstacles automatically (also with --roi)");
  app.add_flag("--rectified", options.input_rectified,
               "the pair is already rectified (P1 P2 Q as given)");
  app.add_option("--method", options.method,
                 fmt::format("matcher: {} (default {})", fmt::join(MatcherNames(), ", "),
                             DefaultMatcherName()));
  AddParamOption(app, &raw_params);
  app.add_option("--min-depth", options.min_depth_m, "working range: nearest depth searched (m)")
      ->capture_default_str();
  app.add_option("--max-depth", options.max_depth_m, "working range: farthest depth searched (m)")
      ->capture_default_str();
  app.add_option("--min-body-width", options.ranging.min_body_width_m,
                 "drop thinner structures (conductors) inside an ROI before ranging (m, 0 = keep)")
      ->capture_default_str();
  app.add_option("--threads", options.threads, "matcher threads (0 = all cores)")
      ->capture_default_str();
  app.add_flag(
      "!--no-search-from-zero", options.search_from_zero,
      "search only the working range's disparities (the background may then match falsely)");
  AddRangingSettingsOption(app, &ranging_settings);
  app.add_option("--disparity-out", disparity_out, "also write the disparity (PFM)");
  app.add_option("--json", json_path, "report (- for stdout)");
  return RunCommand(app, argc, argv, [&] {
    ApplyRangingSettings("--ranging", ranging_settings, &options);
    if (roi_texts.empty() && !automatic)
      throw UsageError("give at least one --roi x,y,w,h or --auto");
    std::vector<cv::Rect> rois;
    for (const std::string& text : roi_texts) rois.push_back(ParseRoi(text));
    options.params = ParseParams(raw_params);
    const StereoCalibration calib = ReadStereoCalibration(calib_path);
    const cv::Mat left = ReadImage(left_path, ImageColor::kColor);
    const cv::Mat right = ReadImage(right_path, ImageColor::kColor);
    CheckSameSize(left, left_path, right, right_path);
    CheckCalibrationMatchesImage(calib, left.size(), calib_path);
    for (const cv::Rect& roi : rois) CheckRoi(roi, left.size());  // before the (slow) matching

    const RangingPipeline pipeline(calib, options);
    Stopwatch watch;
    const RangingFrame frame = pipeline.Process(left, right);
    const double match_ms = watch.ElapsedMs();
    std::vector<RangeResult> results = pipeline.RangeRois(frame, rois);
    if (automatic) {
      for (RangeResult& r : pipeline.RangeAuto(frame)) results.push_back(std::move(r));
    }
    if (!disparity_out.empty()) WritePfm(disparity_out, frame.disparity);

    const DisparityRange range = pipeline.disparity_range();
    const DisparityRange searched = pipeline.search_range();
    std::ostream& out = TableStream(json_path);
    out << fmt::format(
        "method {}, depths {}..{} m -> disparities {}..{} (searched {}..{}), {:.0f} ms\n",
        pipeline.method(), options.min_depth_m, options.max_depth_m, range.min_disparity,
        range.max_disparity(), searched.min_disparity, searched.max_disparity(), match_ms);
    out << fmt::format("{:>3}  {:>6}  {:<20} {:>10} {:>9} {:>7}  {}\n", "#", "source", "box",
                       "distance_m", "sigma_m", "valid%", "note");
    nlohmann::json report = RangingChainSettings(pipeline);
    report["calibration"] = calib_path;
    report["min_depth_m"] = options.min_depth_m;
    report["max_depth_m"] = options.max_depth_m;
    report["distance_definition"] =
        "depth of the obstacle's nearest visible surface along the rectified left optical axis (m)";
    report["obstacles"] = nlohmann::json::array();
    for (size_t i = 0; i < results.size(); ++i) {
      const RangeResult& r = results[i];
      const char* source = i < rois.size() ? "roi" : "auto";
      const cv::Rect b = r.ok() ? r.box : r.roi;
      const std::string box = fmt::format("{},{},{},{}", b.x, b.y, b.width, b.height);
      if (r.ok()) {
        out << fmt::format("{:>3}  {:>6}  {:<20} {:>10.3f} {:>9.3f} {:>7.1f}\n", i + 1, source, box,
                           r.distance_m, r.sigma_m, 100.0 * r.valid_fraction);
      } else {
        out << fmt::format("{:>3}  {:>6}  {:<20} {:>10} {:>9} {:>7.1f}  no measurement: {}\n",
                           i + 1, source, box, "-", "-", 100.0 * r.valid_fraction, r.reason);
      }
      nlohmann::json j = RangeResultToJson(r);
      j["source"] = source;
      report["obstacles"].push_back(j);
    }
    if (!json_path.empty()) WriteJson(json_path, report);
  });
}

}  // namespace linesight::cli
