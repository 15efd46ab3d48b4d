// linesight eval plates: ranging on pairs from an independent renderer (photograph-textured plates
// and boxes at known depths, wall behind inside the ROI), src/linesight/eval/plate_study.h.
#include <iostream>
#include <sstream>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "cli.h"
#include "commands.h"
#include "linesight/core/error.h"
#include "linesight/core/progress.h"
#include "linesight/eval/plate_study.h"
#include "linesight/ranging/ranging_settings.h"
#include "linesight/stereo/matcher.h"

namespace linesight::cli {

int RunEvalPlates(int argc, char** argv) {
  CLI::App app{
      "Ranging accuracy on rectified pairs made by an independent renderer: photograph-textured "
      "plates, slanted plates and boxes at known depths in front of a textured wall (inside the "
      "ROI), ranged through the chain of `linesight range --rectified`.",
      "eval plates"};
  PlateStudyOptions options;
  std::vector<std::string> shape_texts{"plate", "slanted", "box"}, raw_params, ranging_settings;
  std::string json_path, markdown_path, plots_dir, save_dir, texture_dir = options.texture_dir;
  app.add_option("--shapes", shape_texts, "shapes: plate, slanted, box")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--textures", options.textures, "object textures (files under --texture-dir)")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--background", options.background, "wall texture (file under --texture-dir)")
      ->capture_default_str();
  app.add_option("--texture-dir", texture_dir, "folder of the texture photographs")
      ->capture_default_str();
  app.add_option("--distances", options.distances, "true distances (m) of the nearest point")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--runs", options.runs, "captures per scene (fresh read noise each)")
      ->capture_default_str();
  app.add_option("--noise", options.noise_dn, "read noise (DN)")->capture_default_str();
  app.add_option("--supersampling", options.supersampling, "rays per pixel side")
      ->capture_default_str();
  app.add_option("--seed", options.seed, "noise seed")->capture_default_str();
  app.add_option("--width", options.rig.image_size.width, "rig image width (px)")
      ->capture_default_str();
  app.add_option("--height", options.rig.image_size.height, "rig image height (px)")
      ->capture_default_str();
  app.add_option("--focal", options.rig.focal_px, "rig focal length (px)")->capture_default_str();
  app.add_option("--baseline", options.rig.baseline_m, "rig baseline (m)")->capture_default_str();
  app.add_option("--method", options.pipeline.method,
                 fmt::format("matcher: {} (default {})", fmt::join(MatcherNames(), ", "),
                             DefaultMatcherName()));
  AddParamOption(app, &raw_params);
  AddRangingSettingsOption(app, &ranging_settings);
  app.add_option("--min-depth", options.pipeline.min_depth_m, "working range (m)")
      ->capture_default_str();
  app.add_option("--max-depth", options.pipeline.max_depth_m, "working range (m)")
      ->capture_default_str();
  app.add_option("--threads", options.pipeline.threads, "matcher threads (0 = all cores)")
      ->capture_default_str();
  app.add_option("--save", save_dir,
                 "write calib.yml and each scene's first capture (PNG pair + JSON with the true "
                 "distance and the ROI) here, for `linesight range --rectified`");
  app.add_option("--json", json_path, "JSON report (- for stdout)");
  app.add_option("--markdown", markdown_path, "also write the markdown table to this file");
  app.add_option("--plots", plots_dir, "write plates.svg (relative error vs distance) here");
  return RunCommand(app, argc, argv, [&] {
    options.shapes.clear();
    for (const std::string& s : shape_texts) options.shapes.push_back(sim::ParsePlateShape(s));
    options.texture_dir = texture_dir;
    options.save_dir = save_dir;
    options.pipeline.params = ParseParams(raw_params);
    ApplyRangingSettings("--ranging", ranging_settings, &options.pipeline);
    options.Check();
    ProgressBar progress(static_cast<int64_t>(options.shapes.size() * options.textures.size() *
                                              options.distances.size()) *
                             options.runs,
                         "eval plates");
    const PlateStudyReport report = RunPlateStudy(options, &progress);
    progress.Finish();
    EmitReport(report, json_path, markdown_path, plots_dir);
  });
}

}  // namespace linesight::cli
