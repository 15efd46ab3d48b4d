// linesight pattern: render a calibration target to show 1:1 on an LCD panel, with its exact square
// size.
#include <cstdio>

#include <fmt/format.h>

#include "cli.h"
#include "commands.h"
#include "linesight/calib/target.h"
#include "linesight/core/error.h"
#include "linesight/io/image_io.h"
#include "linesight/io/json_io.h"

namespace linesight::cli {

int RunPattern(int argc, char** argv) {
  CLI::App app{
      "Render a calibration target for an LCD panel (flat to well under 0.1 mm). Show the PNG "
      "full-screen "
      "at 1:1 (no scaling); the square size is an integer number of panel pixels, hence exact.",
      "pattern"};
  std::string type = "chessboard", grid = "9x6", screen = "1920x1080", out_path, json_path,
              dictionary = "4x4_50";
  double pitch_mm = 0;
  calib::TargetOptions options;
  app.add_option("--type", type, "chessboard | charuco | circles | acircles")
      ->capture_default_str();
  app.add_option(
         "--grid", grid,
         "COLSxROWS: inner corners (chessboard), squares (charuco), circles (circles, acircles)")
      ->capture_default_str();
  app.add_option("--screen", screen, "panel resolution WIDTHxHEIGHT in pixels")
      ->capture_default_str();
  app.add_option("--pixel-pitch-mm", pitch_mm, "panel pixel pitch in mm (datasheet, e.g. 0.2745)")
      ->required();
  app.add_option("--square-px", options.square_px,
                 "square side / circle spacing in panel pixels (0 = largest)")
      ->capture_default_str();
  app.add_option("--margin-px", options.margin_px,
                 "white margin around the pattern in pixels (0 = one square)")
      ->capture_default_str();
  app.add_option("--dictionary", dictionary, "charuco: ArUco dictionary")->capture_default_str();
  app.add_option("--marker-fraction", options.marker_fraction, "charuco: marker side / square side")
      ->capture_default_str();
  app.add_option("--out", out_path, "PNG to write")->required();
  app.add_option("--json", json_path, "JSON with the exact sizes (- for stdout)");
  return RunCommand(app, argc, argv, [&] {
    if (type == "chessboard") {
      options.type = calib::PatternType::kChessboard;
    } else if (type == "charuco") {
      options.type = calib::PatternType::kCharuco;
    } else if (type == "circles") {
      options.type = calib::PatternType::kCircles;
    } else if (type == "acircles") {
      options.type = calib::PatternType::kAsymmetricCircles;
    } else {
      throw UsageError(
          fmt::format("--type '{}': expected chessboard, charuco, circles or acircles", type));
    }
    if (std::sscanf(grid.c_str(), "%dx%d", &options.cols, &options.rows) != 2) {
      throw UsageError(fmt::format("--grid '{}': expected COLSxROWS, e.g. 9x6", grid));
    }
    if (std::sscanf(screen.c_str(), "%dx%d", &options.screen.width, &options.screen.height) != 2) {
      throw UsageError(fmt::format("--screen '{}': expected WIDTHxHEIGHT, e.g. 1920x1080", screen));
    }
    options.pixel_pitch_m = pitch_mm / 1000.0;
    options.dictionary = dictionary;
    const calib::RenderedTarget target = calib::RenderTarget(options);
    WriteImage(out_path, target.image);
    nlohmann::json json = {{"image", out_path},
                           {"screen", {options.screen.width, options.screen.height}},
                           {"pixel_pitch_m", options.pixel_pitch_m},
                           {"square_px", target.square_px},
                           {"square_m", target.square_m},
                           {"pattern", target.pattern_spec}};
    if (options.type == calib::PatternType::kCharuco) json["marker_m"] = target.marker_m;
    if (!json_path.empty()) WriteJson(json_path, json);
    std::FILE* out = json_path == "-" ? stderr : stdout;
    std::fprintf(out, "wrote %s (%dx%d): square %d px = %.9g m\n", out_path.c_str(),
                 options.screen.width, options.screen.height, target.square_px, target.square_m);
    std::fprintf(out, "show it full-screen at 1:1, then: linesight calibrate --pattern %s ...\n",
                 target.pattern_spec.c_str());
  });
}

}  // namespace linesight::cli
