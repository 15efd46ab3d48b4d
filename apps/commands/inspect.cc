// linesight inspect: the robot's conductor's radius profile and the bird-caging found in it, in one
// pair or a sequence of pairs.
#include <cmath>
#include <filesystem>
#include <iostream>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <opencv2/imgproc.hpp>

#include "cli.h"
#include "commands.h"
#include "linesight/core/error.h"
#include "linesight/core/progress.h"
#include "linesight/io/image_io.h"
#include "linesight/io/json_io.h"
#include "linesight/io/stereo_calibration.h"
#include "linesight/line/conductor_faults.h"
#include "linesight/line/line_obstacles.h"
#include "linesight/ranging/pipeline.h"

namespace linesight::cli {
namespace fs = std::filesystem;

int RunInspect(int argc, char** argv) {
  CLI::App app{
      "The conductor the robot rides on, inspected: its radius profile along the line from the "
      "image edges in both views, bird-caging (a swelling of the strands) and foreign objects on "
      "the line (a nest on top, a sheet hanging from it) with their positions along the line, and "
      "the dampers' roll about the line (a tilted damper is a fault). "
      "--left/--right take one pair or two globs of a sequence (paired in sorted "
      "order; the conductor is tracked from frame to frame).",
      "inspect"};
  std::string calib_path, left_pattern, right_pattern, json_path, crops_dir;
  std::vector<std::string> raw_params;
  bool with_profile = false;
  RangingPipelineOptions pipeline_options;
  ConductorFaultOptions fault_options;
  app.add_option("--calib", calib_path, "stereo calibration (OpenCV YAML)")->required();
  app.add_option("--left", left_pattern, "left image, or a glob of left images")->required();
  app.add_option("--right", right_pattern, "right image, or a glob of right images")->required();
  app.add_flag("--rectified", pipeline_options.input_rectified,
               "the pairs are already rectified (P1 P2 Q as given)");
  app.add_option("--method", pipeline_options.method,
                 fmt::format("matcher: {} (default {})", fmt::join(MatcherNames(), ", "),
                             DefaultMatcherName()));
  AddParamOption(app, &raw_params);
  app.add_option("--max-arc", fault_options.max_arc_m,
                 "inspect the line up to this far along it from the robot (m)")
      ->capture_default_str();
  app.add_option("--min-swelling", fault_options.min_swelling,
                 "smallest radius increase reported as bird-caging (share of the radius)")
      ->capture_default_str();
  app.add_option("--threads", pipeline_options.threads, "matcher threads (0 = all cores)")
      ->capture_default_str();
  app.add_option("--json", json_path, "report (- for stdout)");
  app.add_option("--crops", crops_dir, "write a crop of the rectified left image per fault here");
  app.add_flag("--profile", with_profile, "add the radius profile along the line to the report");
  return RunCommand(app, argc, argv, [&] {
    fault_options.Check();
    std::vector<fs::path> lefts = ExpandGlob(left_pattern);
    std::vector<fs::path> rights = ExpandGlob(right_pattern);
    if (lefts.size() != rights.size()) {
      throw UsageError(
          fmt::format("--left matches {} files but --right matches {}: the pairs "
                      "must match one to one",
                      lefts.size(), rights.size()));
    }
    pipeline_options.params = LineMatcherParams(pipeline_options.method, ParseParams(raw_params));
    const StereoCalibration calib = ReadStereoCalibration(calib_path);
    const RangingPipeline pipeline(calib, pipeline_options);
    const StereoGeometry geometry = GeometryFromCalibration(calib);
    if (!crops_dir.empty()) fs::create_directories(crops_dir);

    std::ostream& out = TableStream(json_path);
    nlohmann::json report = {{"calibration", calib_path},
                             {"method", pipeline.method()},
                             {"max_arc_m", fault_options.max_arc_m},
                             {"frames", nlohmann::json::array()}};
    ProgressBar progress(static_cast<int64_t>(lefts.size()), "inspect", lefts.size() > 1);
    ConductorModel previous;
    for (size_t i = 0; i < lefts.size(); ++i) {
      const cv::Mat left = ReadImage(lefts[i], ImageColor::kColor);
      const cv::Mat right = ReadImage(rights[i], ImageColor::kColor);
      CheckSameSize(left, lefts[i], right, rights[i]);
      CheckCalibrationMatchesImage(calib, left.size(), calib_path);
      const RangingFrame frame = pipeline.Process(left, right);
      const LineObstacles line =
          FindLineObstacles(pipeline, frame, {}, previous.ok() ? &previous : nullptr);
      previous = line.conductor;
      const ConductorInspection inspection =
          InspectConductor(frame.left_rectified, frame.right_rectified, frame.checked_disparity,
                           line, geometry, fault_options);

      nlohmann::json j = inspection.ToJson(with_profile);
      j["left"] = lefts[i].string();
      j["right"] = rights[i].string();
      // The fittings the inspection checked (and the foreign objects), as FindLineObstacles found
      // them.
      j["obstacles"] = line.ToJson()["obstacles"];
      if (inspection.status == InspectionStatus::kOk) {
        out << fmt::format(
            "{}: conductor radius {:.1f} mm, inspected {:.2f} m of line up to {:.2f} m, "
            "{} fault(s)\n",
            lefts[i].filename().string(), 1000 * inspection.radius_m, inspection.inspected_m,
            inspection.inspected_to_m, inspection.faults.size());
      } else {
        out << fmt::format("{}: {}: {}\n", lefts[i].filename().string(),
                           InspectionStatusName(inspection.status), inspection.reason);
      }
      for (const FittingState& state : inspection.fittings) {
        out << (std::isfinite(state.roll_deg)
                    ? fmt::format("  damper at {:.2f} m along the line: roll {:+.1f} deg\n",
                                  state.arc_m, state.roll_deg)
                    : fmt::format("  damper at {:.2f} m along the line: roll not measured ({} "
                                  "cross-sections of the line beside it)\n",
                                  state.arc_m, state.axis_samples));
      }
      for (size_t k = 0; k < inspection.faults.size(); ++k) {
        const ConductorFault& f = inspection.faults[k];
        out << fmt::format(
            "  {:<15} {:.2f}..{:.2f} m along the line, {:.2f} m away, size {:.1f} mm{}, "
            "confidence {:.2f}\n",
            ConductorFaultTypeName(f.type), f.arc_begin_m, f.arc_end_m, f.distance_m,
            1000 * f.size_m,
            f.type == ConductorFaultType::kDamperTilted
                ? fmt::format(" (roll {:+.1f} deg)", f.roll_deg)
                : "",
            f.confidence);
        if (!crops_dir.empty() && !f.box.empty()) {
          const int pad = std::max(8, f.box.width / 2);
          const cv::Rect crop =
              (f.box + cv::Size(2 * pad, 2 * pad) - cv::Point(pad, pad)) &
              cv::Rect(0, 0, frame.left_rectified.cols, frame.left_rectified.rows);
          const fs::path file =
              fs::path(crops_dir) / fmt::format("{}_fault{}_{}.png", lefts[i].stem().string(),
                                                k + 1, ConductorFaultTypeName(f.type));
          WriteImage(file, frame.left_rectified(crop));
          j["faults"][k]["crop"] = file.string();
        }
      }
      report["frames"].push_back(std::move(j));
      progress.Advance(1, lefts[i].filename().string());
    }
    progress.Finish();
    if (!json_path.empty()) WriteJson(json_path, report);
  });
}

}  // namespace linesight::cli
