#include "cli.h"

#include <cstdio>
#include <exception>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "linesight/core/error.h"
#include "linesight/core/key_value.h"
#include "linesight/ranging/ranging_settings.h"

namespace linesight::cli {

int RunCommand(CLI::App& app, int argc, char** argv, const std::function<void()>& body) {
  const std::string name = app.get_name();
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "%s: %s (see --help)\n", name.c_str(), e.what());
    return kExitUsage;
  }
  try {
    body();
    return kExitOk;
  } catch (const UsageError& e) {
    std::fprintf(stderr, "%s: %s\n", name.c_str(), e.what());
    return kExitUsage;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: %s\n", name.c_str(), e.what());
    return kExitRuntimeError;
  }
}

void AddParamOption(CLI::App& app, std::vector<std::string>* raw) {
  app.add_option(
         "--param", *raw,
         "method parameter key=value (repeatable, or comma-separated); `linesight disparity "
         "--help` lists each method's keys")
      ->delimiter(',');
}

std::map<std::string, std::string> ParseParams(const std::vector<std::string>& raw) {
  return ParseKeyValues("--param", raw);
}

void AddLineGeometryOptions(CLI::App& app, double* conductor_offset_x_m,
                            double* conductor_offset_y_m, double* conductor_yaw_rad,
                            double* tower_offset_x_m) {
  app.add_option("--conductor-offset-x", *conductor_offset_x_m,
                 "x of the conductor axis at the camera, in the left camera frame (m); 0.06 = rig "
                 "centred under the line")
      ->capture_default_str();
  app.add_option("--conductor-offset-y", *conductor_offset_y_m,
                 "y of the conductor axis at the camera (m; < 0 = above the camera)")
      ->capture_default_str();
  app.add_option("--conductor-yaw", *conductor_yaw_rad,
                 "heading of the line about the camera y axis (rad)")
      ->capture_default_str();
  app.add_option("--tower-offset-x", *tower_offset_x_m,
                 "x offset of the end tower's body from the middle of the conductors (m)")
      ->capture_default_str();
}

void AddSourceOptions(CLI::App& app, std::string* spec, FrameSourceOptions* options) {
  app.add_option("--source", *spec,
                 fmt::format("where pairs come from: {}", fmt::join(FrameSourceSchemes(), " | ")))
      ->required();
  app.add_option("--width", options->width, "camera frame width (px; 0 = device default)");
  app.add_option("--height", options->height, "camera frame height (px; 0 = device default)");
  app.add_option("--fps", options->fps, "camera frame rate (0 = device default)");
  app.add_flag("--loop", options->loop, "start image sequences and videos again at their end");
  app.add_option("--synthetic-speed", options->synthetic_speed_mps,
                 "synthetic source: the robot's speed toward the obstacles on its line (m/s; 0 = "
                 "the still scene)")
      ->capture_default_str();
  app.add_option("--synthetic-start", options->synthetic_start_m,
                 "synthetic source: distance along the line to the first obstacle at the first "
                 "frame (m)")
      ->capture_default_str();
  app.add_option("--synthetic-obstacles", options->synthetic_obstacles,
                 "synthetic source: the still scene with these obstacles, type:distance_m,... "
                 "(e.g. damper:1.5,clamp:3,insulator:4.5)");
  app.add_option("--synthetic-supersampling", options->synthetic_supersampling,
                 "synthetic source: rays per pixel side (1 = fastest)")
      ->capture_default_str();
}

void AddRangingSettingsOption(CLI::App& app, std::vector<std::string>* raw) {
  app.add_option("--ranging", *raw,
                 "ranging setting key=value (repeatable, or comma-separated); the keys are listed "
                 "below")
      ->delimiter(',');
  const std::string footer = app.get_footer();
  app.footer((footer.empty() ? "" : footer + "\n\n") +
             "--ranging settings (key = default (accepted values): meaning):\n" +
             RangingSettingsTable().Help());
}

}  // namespace linesight::cli
