// Obstacle types and specs, and the checks of PowerLineSceneOptions (power_line_scene.h; the
// defect specs are checked by defect_specs.cc).
#include <algorithm>
#include <cmath>
#include <exception>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "linesight/core/error.h"
#include "linesight/sim/power_line_internal.h"
#include "linesight/sim/power_line_scene.h"

namespace linesight::sim {

std::string ObstacleTypeName(ObstacleType type) {
  switch (type) {
    case ObstacleType::kDamper:
      return "damper";
    case ObstacleType::kSuspensionClamp:
      return "clamp";
    case ObstacleType::kInsulatorString:
      return "insulator";
  }
  return "unknown";
}

ObstacleType ParseObstacleType(std::string_view name) {
  if (name == "damper" || name == "counterweight" || name == "stockbridge") {
    return ObstacleType::kDamper;
  }
  if (name == "clamp" || name == "suspension_clamp") return ObstacleType::kSuspensionClamp;
  if (name == "insulator" || name == "insulator_string") return ObstacleType::kInsulatorString;
  throw InputError(
      fmt::format("unknown obstacle type '{}': expected damper, clamp or insulator", name));
}

std::vector<ObstacleType> AllObstacleTypes() {
  return {ObstacleType::kDamper, ObstacleType::kSuspensionClamp, ObstacleType::kInsulatorString};
}

std::vector<ObstacleSpec> ParseObstacleSpecs(std::string_view text) {
  std::vector<ObstacleSpec> specs;
  if (text.empty()) return specs;
  size_t start = 0;
  while (start <= text.size()) {
    const size_t end = std::min(text.find(',', start), text.size());
    const std::string entry(text.substr(start, end - start));
    start = end + 1;
    std::vector<std::string> parts;
    size_t p = 0;
    while (true) {
      const size_t colon = entry.find(':', p);
      parts.push_back(entry.substr(p, colon == std::string::npos ? std::string::npos : colon - p));
      if (colon == std::string::npos) break;
      p = colon + 1;
    }
    // A trailing key=value: the tilt of a damaged damper.
    std::optional<std::string> tilt;
    if (parts.size() >= 3 && parts.back().find('=') != std::string::npos) {
      const std::string& kv = parts.back();
      const size_t eq = kv.find('=');
      if (kv.substr(0, eq) != "tilt") {
        throw InputError(fmt::format("obstacle '{}': unknown key '{}' (expected tilt=deg)", entry,
                                     kv.substr(0, eq)));
      }
      tilt = kv.substr(eq + 1);
      parts.pop_back();
    }
    if (parts.size() < 2 || parts.size() > 3) {
      throw InputError(fmt::format(
          "obstacle '{}': expected type:distance_m[:conductor][:tilt=deg], e.g. damper:1.5",
          entry));
    }
    ObstacleSpec spec;
    try {
      spec.type = ParseObstacleType(parts[0]);
    } catch (const InputError& e) {
      throw InputError(fmt::format("obstacle '{}': {}", entry, e.what()));
    }
    auto parse_number = [&](const std::string& s, const char* what) {
      size_t used = 0;
      double value = 0;
      try {
        value = std::stod(s, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used != s.size() || s.empty() || !std::isfinite(value)) {
        throw InputError(fmt::format("obstacle '{}': {} '{}' is not a number", entry, what, s));
      }
      return value;
    };
    spec.distance_m = parse_number(parts[1], "distance");
    if (parts.size() == 3) {
      const double conductor = parse_number(parts[2], "conductor index");
      if (conductor != std::floor(conductor) || conductor < 0 || conductor > 16) {
        throw InputError(
            fmt::format("obstacle '{}': conductor index must be an integer >= 0", entry));
      }
      spec.conductor = static_cast<int>(conductor);
    }
    if (tilt) {
      spec.tilt_deg = parse_number(*tilt, "tilt");
      if (spec.type != ObstacleType::kDamper || std::fabs(spec.tilt_deg) > 60) {
        throw InputError(fmt::format(
            "obstacle '{}': tilt must be in [-60, 60] deg and only a damper may be tilted", entry));
      }
    }
    specs.push_back(spec);
    if (end == text.size()) break;
  }
  return specs;
}

void PowerLineSceneOptions::Check() const {
  rig.Check();
  sensor.Check();
  CheckOption(num_conductors >= 1 && num_conductors <= 4, "PowerLineSceneOptions.num_conductors",
              num_conductors, "must be in [1, 4]");
  CheckOption(obstacles.size() <= 255, "PowerLineSceneOptions.obstacles", obstacles.size(),
              "at most 255 obstacles (8-bit id mask)");
  for (size_t i = 0; i < obstacles.size(); ++i) {
    const ObstacleSpec& o = obstacles[i];
    const std::string name = fmt::format("PowerLineSceneOptions.obstacles[{}]", i);
    CheckOption(std::isfinite(o.distance_m) && o.distance_m >= 0.2 && o.distance_m <= 80,
                (name + ".distance_m").c_str(), o.distance_m, "must be in [0.2, 80] m");
    CheckOption(o.distance_m < 0.9 * span_ahead_m, (name + ".distance_m").c_str(), o.distance_m,
                "must be shorter than 0.9 * span_ahead_m (the conductor ends at the next tower)");
    CheckOption(o.conductor >= 0 && o.conductor < num_conductors, (name + ".conductor").c_str(),
                o.conductor, "must be a conductor index in [0, num_conductors)");
    CheckOption(std::isfinite(o.tilt_deg) && std::fabs(o.tilt_deg) <= 60 &&
                    (o.tilt_deg == 0 || o.type == ObstacleType::kDamper),
                (name + ".tilt_deg").c_str(), o.tilt_deg,
                "must be in [-60, 60] deg, and 0 unless the obstacle is a damper");
    if (o.arc_m) {
      CheckOption(std::isfinite(*o.arc_m) && *o.arc_m >= -5 && *o.arc_m <= 0.9 * span_ahead_m,
                  (name + ".arc_m").c_str(), *o.arc_m, "must be in [-5, 0.9 * span_ahead_m] m");
    }
  }
  CheckOption(defects.size() <= 255, "PowerLineSceneOptions.defects", defects.size(),
              "at most 255 defects (8-bit id mask)");
  for (size_t i = 0; i < defects.size(); ++i) {
    const DefectSpec& d = defects[i];
    const std::string name = fmt::format("PowerLineSceneOptions.defects[{}]", i);
    CheckOption(std::isfinite(d.arc_m) && d.arc_m >= -50 && d.arc_m <= 0.9 * span_ahead_m,
                (name + ".arc_m").c_str(), d.arc_m, "must be in [-50, 0.9 * span_ahead_m] m");
    detail::CheckDefectSpec(d, name);
  }
  CheckOption(std::fabs(conductor_offset_x_m) <= 2, "PowerLineSceneOptions.conductor_offset_x_m",
              conductor_offset_x_m, "must be in [-2, 2] m");
  CheckOption(std::fabs(conductor_offset_y_m) <= 2 &&
                  std::hypot(conductor_offset_x_m, conductor_offset_y_m) > 2 * conductor_radius_m,
              "PowerLineSceneOptions.conductor_offset_y_m", conductor_offset_y_m,
              "must be in [-2, 2] m and keep the conductor clear of the camera");
  CheckOption(conductor_radius_m >= 0.002 && conductor_radius_m <= 0.05,
              "PowerLineSceneOptions.conductor_radius_m", conductor_radius_m,
              "must be in [0.002, 0.05] m");
  CheckOption(conductor_spacing_m >= 4 * conductor_radius_m && conductor_spacing_m <= 10,
              "PowerLineSceneOptions.conductor_spacing_m", conductor_spacing_m,
              "must be in [4 * conductor_radius_m, 10] m");
  CheckOption(std::isfinite(tower_offset_x_m) && std::fabs(tower_offset_x_m) <= 20,
              "PowerLineSceneOptions.tower_offset_x_m", tower_offset_x_m, "must be in [-20, 20] m");
  CheckOption(std::fabs(conductor_yaw_rad) <= 0.5, "PowerLineSceneOptions.conductor_yaw_rad",
              conductor_yaw_rad, "must be in [-0.5, 0.5] rad");
  CheckOption(std::fabs(conductor_pitch_rad) <= 0.5, "PowerLineSceneOptions.conductor_pitch_rad",
              conductor_pitch_rad, "must be in [-0.5, 0.5] rad");
  CheckOption(std::fabs(conductor_roll_rad) <= 0.3, "PowerLineSceneOptions.conductor_roll_rad",
              conductor_roll_rad, "must be in [-0.3, 0.3] rad");
  CheckOption(sag_parameter_m >= 50 && sag_parameter_m <= 1e6,
              "PowerLineSceneOptions.sag_parameter_m", sag_parameter_m, "must be in [50, 1e6] m");
  CheckOption(span_ahead_m >= 10 && span_ahead_m <= 1000, "PowerLineSceneOptions.span_ahead_m",
              span_ahead_m, "must be in [10, 1000] m");
  CheckOption(conductor_strands >= 6 && conductor_strands <= 60,
              "PowerLineSceneOptions.conductor_strands", conductor_strands, "must be in [6, 60]");
  CheckOption(conductor_lay_length_m >= 0.02 && conductor_lay_length_m <= 2,
              "PowerLineSceneOptions.conductor_lay_length_m", conductor_lay_length_m,
              "must be in [0.02, 2] m");
  CheckOption(ground_depth_m >= 1 && ground_depth_m <= 200, "PowerLineSceneOptions.ground_depth_m",
              ground_depth_m, "must be in [1, 200] m");
  CheckOption(cloud_cover >= 0 && cloud_cover <= 1, "PowerLineSceneOptions.cloud_cover",
              cloud_cover, "must be in [0, 1]");
  CheckOption(sun_elevation_deg >= 5 && sun_elevation_deg <= 90,
              "PowerLineSceneOptions.sun_elevation_deg", sun_elevation_deg,
              "must be in [5, 90] deg");
  CheckOption(sun_azimuth_deg >= -180 && sun_azimuth_deg <= 180,
              "PowerLineSceneOptions.sun_azimuth_deg", sun_azimuth_deg,
              "must be in [-180, 180] deg");
  CheckOption(ambient >= 0 && ambient <= 1, "PowerLineSceneOptions.ambient", ambient,
              "must be in [0, 1]");
}

}  // namespace linesight::sim
