// Conductor defect types and specs (power_line_scene.h): names, the text form, the range checks
// and seeded random defects.
#include <algorithm>
#include <cmath>
#include <exception>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "linesight/core/error.h"
#include "linesight/sim/power_line_internal.h"
#include "linesight/sim/power_line_scene.h"
#include "linesight/sim/procedural_texture.h"

namespace linesight::sim {

namespace {

// Range of DefectSpec::length_m for each type (m).
struct LengthRange {
  double lo, hi;
};
LengthRange LengthRangeOf(DefectType type) {
  switch (type) {
    case DefectType::kBirdcage:
      return {0.03, 0.5};
    case DefectType::kBrokenStrands:  // not used; any valid length of another type passes
      return {0.03, 1.5};
    case DefectType::kHangingString:
      return {0.03, 1.5};
    case DefectType::kPlasticSheet:
      return {0.03, 0.6};
    case DefectType::kBirdNest:
      return {0.05, 0.6};
  }
  return {0.0, 0.0};
}

// The keys of the text form that apply to a type.
std::vector<std::string> KeysOf(DefectType type) {
  switch (type) {
    case DefectType::kBirdcage:
      return {"swelling", "length"};
    case DefectType::kBrokenStrands:
      return {"strands", "standoff", "angle"};
    case DefectType::kHangingString:
      return {"length", "angle"};
    case DefectType::kPlasticSheet:
      return {"length", "side", "angle"};
    case DefectType::kBirdNest:
      return {"length", "diameter"};
  }
  return {};
}

std::vector<std::string> Split(const std::string& text, char separator) {
  std::vector<std::string> parts;
  size_t start = 0;
  while (true) {
    const size_t end = text.find(separator, start);
    parts.push_back(text.substr(start, end == std::string::npos ? std::string::npos : end - start));
    if (end == std::string::npos) break;
    start = end + 1;
  }
  return parts;
}

}  // namespace

std::string DefectTypeName(DefectType type) {
  switch (type) {
    case DefectType::kBirdcage:
      return "birdcage";
    case DefectType::kBrokenStrands:
      return "broken_strands";
    case DefectType::kHangingString:
      return "string";
    case DefectType::kPlasticSheet:
      return "sheet";
    case DefectType::kBirdNest:
      return "nest";
  }
  return "unknown";
}

DefectType ParseDefectType(std::string_view name) {
  if (name == "birdcage") return DefectType::kBirdcage;
  if (name == "broken_strands" || name == "broken-strands") return DefectType::kBrokenStrands;
  if (name == "string" || name == "hanging_string") return DefectType::kHangingString;
  if (name == "sheet" || name == "plastic_sheet") return DefectType::kPlasticSheet;
  if (name == "nest" || name == "bird_nest") return DefectType::kBirdNest;
  throw InputError(fmt::format(
      "unknown defect type '{}': expected birdcage, broken_strands, string, sheet or nest", name));
}

std::vector<DefectType> AllDefectTypes() {
  return {DefectType::kBirdcage, DefectType::kBrokenStrands, DefectType::kHangingString,
          DefectType::kPlasticSheet, DefectType::kBirdNest};
}

namespace detail {

void CheckDefectSpec(const DefectSpec& spec, const std::string& name) {
  CheckOption(spec.swelling >= 0.05 && spec.swelling <= 1.0, (name + ".swelling").c_str(),
              spec.swelling, "must be in [0.05, 1]");
  const LengthRange length = LengthRangeOf(spec.type);
  CheckOption(
      spec.length_m >= length.lo && spec.length_m <= length.hi, (name + ".length_m").c_str(),
      spec.length_m,
      fmt::format("must be in [{}, {}] m for a {}", length.lo, length.hi, DefectTypeName(spec.type))
          .c_str());
  CheckOption(spec.strands >= 1 && spec.strands <= 3, (name + ".strands").c_str(), spec.strands,
              "must be in [1, 3]");
  CheckOption(spec.standoff_m >= 0.002 && spec.standoff_m <= 0.08, (name + ".standoff_m").c_str(),
              spec.standoff_m, "must be in [0.002, 0.08] m");
  CheckOption(spec.angle_deg >= -360 && spec.angle_deg <= 360, (name + ".angle_deg").c_str(),
              spec.angle_deg, "must be in [-360, 360] deg");
}

}  // namespace detail

std::vector<DefectSpec> ParseDefectSpecs(std::string_view text) {
  std::vector<DefectSpec> specs;
  if (text.empty()) return specs;
  for (const std::string& entry : Split(std::string(text), ',')) {
    const std::vector<std::string> parts = Split(entry, ':');
    if (parts.size() < 2) {
      throw InputError(fmt::format(
          "defect '{}': expected type:arc_m[:key=value]..., e.g. birdcage:2.0:swelling=0.3",
          entry));
    }
    DefectSpec spec;
    try {
      spec.type = ParseDefectType(parts[0]);
    } catch (const InputError& e) {
      throw InputError(fmt::format("defect '{}': {}", entry, e.what()));
    }
    auto parse_number = [&](const std::string& s, const std::string& what) {
      size_t used = 0;
      double value = 0;
      try {
        value = std::stod(s, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (s.empty() || used != s.size() || !std::isfinite(value)) {
        throw InputError(fmt::format("defect '{}': {} '{}' is not a number", entry, what, s));
      }
      return value;
    };
    spec.arc_m = parse_number(parts[1], "arc");
    const std::vector<std::string> keys = KeysOf(spec.type);
    for (size_t i = 2; i < parts.size(); ++i) {
      const size_t equals = parts[i].find('=');
      const std::string key = parts[i].substr(0, equals);
      if (equals == std::string::npos || std::find(keys.begin(), keys.end(), key) == keys.end()) {
        throw InputError(fmt::format("defect '{}': '{}' is not a key=value of a {} (keys: {})",
                                     entry, parts[i], DefectTypeName(spec.type),
                                     fmt::join(keys, ", ")));
      }
      const double value = parse_number(parts[i].substr(equals + 1), key);
      if (key == "swelling") {
        spec.swelling = value;
      } else if (key == "length" || key == "side" || key == "diameter") {
        spec.length_m = value;
      } else if (key == "strands") {
        if (value != std::floor(value) || value < 1 || value > 3) {
          throw InputError(
              fmt::format("defect '{}': strands = {} must be an integer in [1, 3]", entry, value));
        }
        spec.strands = static_cast<int>(value);
      } else if (key == "standoff") {
        spec.standoff_m = value;
      } else if (key == "angle") {
        spec.angle_deg = value;
      }
    }
    try {
      detail::CheckDefectSpec(spec, "DefectSpec");
    } catch (const OptionError& e) {
      throw InputError(fmt::format("defect '{}': {}", entry, e.what()));
    }
    specs.push_back(spec);
  }
  return specs;
}

std::vector<DefectSpec> RandomDefects(std::uint64_t seed, int count, double min_arc_m,
                                      double max_arc_m) {
  constexpr double kMinGap = 0.5;
  CheckOption(count >= 0 && count <= 255, "RandomDefects count", count, "must be in [0, 255]");
  if (count == 0) return {};
  const double slack = max_arc_m - min_arc_m - kMinGap * (count - 1);
  if (!std::isfinite(slack) || slack < 0) {
    throw InputError(fmt::format("{} defects {} m apart do not fit between arc {} m and {} m",
                                 count, kMinGap, min_arc_m, max_arc_m));
  }
  detail::NoiseStream random(detail::Mix64(seed ^ 0xdefec75ULL));
  // Uniform positions under the minimum gap: sorted offsets into the slack, then the gaps added.
  std::vector<double> offsets(static_cast<size_t>(count));
  for (double& offset : offsets) offset = slack * random.Uniform();
  std::sort(offsets.begin(), offsets.end());
  const std::vector<DefectType> types = AllDefectTypes();
  auto between = [&](double lo, double hi) { return lo + (hi - lo) * random.Uniform(); };
  std::vector<DefectSpec> defects;
  for (int i = 0; i < count; ++i) {
    DefectSpec spec;
    spec.type = types[std::min<size_t>(types.size() - 1,
                                       static_cast<size_t>(random.Uniform() * types.size()))];
    spec.arc_m = min_arc_m + offsets[static_cast<size_t>(i)] + kMinGap * i;
    switch (spec.type) {
      case DefectType::kBirdcage:
        spec.swelling = between(0.1, 0.5);
        spec.length_m = between(0.05, 0.3);
        break;
      case DefectType::kBrokenStrands:
        spec.strands = std::min(3, 1 + static_cast<int>(random.Uniform() * 3));
        spec.standoff_m = between(0.003, 0.05);
        spec.angle_deg = between(0.0, 360.0);
        break;
      case DefectType::kHangingString:
        spec.length_m = between(0.05, 0.6);
        spec.angle_deg = between(-30.0, 30.0);
        break;
      case DefectType::kPlasticSheet:
        spec.length_m = between(0.05, 0.4);
        spec.angle_deg = between(-30.0, 30.0);
        break;
      case DefectType::kBirdNest:
        spec.length_m = between(0.15, 0.4);
        break;
    }
    defects.push_back(spec);
  }
  return defects;
}

}  // namespace linesight::sim
