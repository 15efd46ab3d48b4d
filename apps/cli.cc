#include "cli.h"

#include <cmath>
#include <cstdio>
#include <exception>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "linesight/core/error.h"

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
  std::map<std::string, std::string> out;
  for (const std::string& entry : raw) {
    const auto eq = entry.find('=');
    if (eq == std::string::npos || eq == 0) {
      throw UsageError("--param '" + entry + "': expected key=value");
    }
    out[entry.substr(0, eq)] = entry.substr(eq + 1);
  }
  return out;
}

void AddSourceOptions(CLI::App& app, std::string* spec, FrameSourceOptions* options) {
  app.add_option("--source", *spec,
                 fmt::format("where pairs come from: {}", fmt::join(FrameSourceSchemes(), " | ")))
      ->required();
  app.add_option("--width", options->width, "camera frame width (px; 0 = device default)");
  app.add_option("--height", options->height, "camera frame height (px; 0 = device default)");
  app.add_option("--fps", options->fps, "camera frame rate (0 = device default)");
  app.add_flag("--loop", options->loop, "start image sequences and videos again at their end");
  app.add_option(
      "--synthetic-obstacles", options->synthetic_obstacles,
      "synthetic source: type:distance_m,... (default damper:1.5,clamp:3,insulator:4.5)");
  app.add_option("--synthetic-supersampling", options->synthetic_supersampling,
                 "synthetic source: rays per pixel side (1 = fastest)")
      ->capture_default_str();
}

void AddRangingSettingsOption(CLI::App& app, std::vector<std::string>* raw) {
  app.add_option(
         "--ranging", *raw,
         "ranging setting key=value (repeatable, or comma-separated): near_percentile, "
         "core_fraction, "
         "silhouette_margin_x_px, silhouette_margin_y_px, fill_rejected_holes (0|1), "
         "min_body_width_m, largest_mode_without_bodies (0|1), "
         "min_body_width_px, smoothing_radius_px, checked (0|1), "
         "model_relative_sigma, search_from_zero (0|1), surface_refinement (0|1|2|3), "
         "surface_disagreement_weight, surface_band_relative, surface_gradient_ratio, "
         "surface_min_ncc, surface_min_pixels, surface_interior (0|1), edge_fallback (0|1), "
         "edge_min_rows, edge_min_contrast, edge_row_extension, edge_max_slope, "
         "edge_surface_plateau")
      ->delimiter(',');
}

namespace {

// `value` of `setting` as an int in [lo, hi]; a fraction or a value outside is a usage error.
int WholeSetting(const std::string& setting, double value, int lo, int hi) {
  if (value != std::floor(value) || value < lo || value > hi) {
    throw UsageError(
        fmt::format("--ranging '{}': expected a whole number {}..{}", setting, lo, hi));
  }
  return int(value);
}

}  // namespace

void ApplyRangingSettings(const std::vector<std::string>& settings,
                          RangingPipelineOptions* options_out) {
  RangingPipelineOptions& options = *options_out;
  for (const std::string& setting : settings) {
    const size_t eq = setting.find('=');
    const std::string key = setting.substr(0, eq);
    double value = 0.0;
    try {
      size_t used = 0;
      const std::string text = eq == std::string::npos ? "" : setting.substr(eq + 1);
      value = std::stod(text, &used);
      if (used != text.size() || !std::isfinite(value)) throw std::invalid_argument(text);
    } catch (const std::exception&) {
      throw UsageError(fmt::format("--ranging '{}': expected key=value with a number", setting));
    }
    if (key == "near_percentile") {
      options.ranging.near_percentile = value;
    } else if (key == "core_fraction") {
      options.ranging.core_fraction = value;
    } else if (key == "silhouette_margin_x_px") {
      options.ranging.silhouette_margin_x_px = WholeSetting(setting, value, 0, 1000000);
    } else if (key == "silhouette_margin_y_px") {
      options.ranging.silhouette_margin_y_px = WholeSetting(setting, value, 0, 1000000);
    } else if (key == "fill_rejected_holes") {
      options.ranging.fill_rejected_holes = value != 0.0;
    } else if (key == "largest_mode_without_bodies") {
      options.ranging.largest_mode_without_bodies = value != 0.0;
    } else if (key == "min_body_width_m") {
      options.ranging.min_body_width_m = value;
    } else if (key == "min_body_width_px") {
      options.ranging.min_body_width_px = value;
    } else if (key == "smoothing_radius_px") {
      options.ranging.smoothing_radius_px = WholeSetting(setting, value, 0, 1000000);
    } else if (key == "checked") {
      options.range_on_checked_disparity = value != 0.0;
    } else if (key == "model_relative_sigma") {
      options.model_relative_sigma = value;
    } else if (key == "surface_refinement") {
      options.surface_refinement = WholeSetting(setting, value, 0, 3);
    } else if (key == "surface_disagreement_weight") {
      options.surface_disagreement_weight = value;
    } else if (key == "surface_gradient_ratio") {
      options.surface.gradient_ratio = value;
    } else if (key == "surface_interior") {
      options.surface.interior_only = value != 0.0;
    } else if (key == "surface_min_pixels") {
      options.surface.min_pixels = WholeSetting(setting, value, 3, 1000000);
    } else if (key == "surface_min_ncc") {
      options.surface.min_ncc = value;
    } else if (key == "surface_band_relative") {
      options.ranging.surface_band_relative = value;
    } else if (key == "edge_fallback") {
      options.edge_fallback = value != 0.0;
    } else if (key == "edge_min_rows") {
      options.edges.min_rows = WholeSetting(setting, value, 1, 1000000);
    } else if (key == "edge_row_extension") {
      options.edges.row_extension_px = WholeSetting(setting, value, 0, 32);
    } else if (key == "edge_surface_plateau") {
      options.edges.surface_plateau_px = WholeSetting(setting, value, 1, 16);
    } else if (key == "edge_max_slope") {
      options.edges.max_slope = value;
    } else if (key == "edge_min_contrast") {
      options.edges.min_contrast = value;
    } else if (key == "search_from_zero") {
      options.search_from_zero = value != 0.0;
    } else {
      throw UsageError(fmt::format("--ranging '{}': expected key=value with a known key", setting));
    }
  }
}

}  // namespace linesight::cli
