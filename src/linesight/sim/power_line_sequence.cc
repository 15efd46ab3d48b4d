#include "linesight/sim/power_line_sequence.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include <fmt/format.h>

#include "linesight/core/atomic_file.h"
#include "linesight/core/error.h"
#include "linesight/io/image_io.h"
#include "linesight/io/json_io.h"
#include "linesight/sim/procedural_texture.h"
#include "linesight/sim/sim_internal.h"

namespace linesight::sim {

namespace {

constexpr double kDegree = std::numbers::pi / 180.0;

// Frequencies of the motion (Hz): a slow sway of the hanging robot and a faster vibration of the
// line and the drive; each channel (pitch, roll, bounce) mixes one of each with seeded phases.
constexpr double kSwayHz = 0.45, kVibrationHz = 2.7, kBounceHz = 3.9;

}  // namespace

void PowerLineSequenceOptions::Check() const {
  scene.Check();
  CheckOption(std::isfinite(fps) && fps >= 0.5 && fps <= 120, "PowerLineSequenceOptions.fps", fps,
              "must be in [0.5, 120] Hz");
  CheckOption(std::isfinite(speed_mps) && speed_mps >= 0.02 && speed_mps <= 3,
              "PowerLineSequenceOptions.speed_mps", speed_mps, "must be in [0.02, 3] m/s");
  CheckOption(std::isfinite(end_gap_m) && end_gap_m >= 0.2, "PowerLineSequenceOptions.end_gap_m",
              end_gap_m, "must be >= 0.2 m");
  CheckOption(std::isfinite(start_gap_m) && start_gap_m > end_gap_m && start_gap_m <= 30,
              "PowerLineSequenceOptions.start_gap_m", start_gap_m, "must be in (end_gap_m, 30] m");
  CheckOption(num_obstacles >= 1 && num_obstacles <= 6, "PowerLineSequenceOptions.num_obstacles",
              num_obstacles, "must be in [1, 6]");
  CheckOption(tilted_damper_share >= 0 && tilted_damper_share <= 1,
              "PowerLineSequenceOptions.tilted_damper_share", tilted_damper_share,
              "must be in [0, 1]");
  CheckOption(num_defects >= 0 && num_defects <= 6, "PowerLineSequenceOptions.num_defects",
              num_defects, "must be in [0, 6]");
  CheckOption(std::isfinite(min_spacing_m) && min_spacing_m >= 0.3,
              "PowerLineSequenceOptions.min_spacing_m", min_spacing_m, "must be >= 0.3 m");
  CheckOption(std::isfinite(max_spacing_m) && max_spacing_m >= min_spacing_m && max_spacing_m <= 10,
              "PowerLineSequenceOptions.max_spacing_m", max_spacing_m,
              "must be in [min_spacing_m, 10] m");
  CheckOption(std::isfinite(pitch_jitter_deg) && pitch_jitter_deg >= 0 && pitch_jitter_deg <= 5,
              "PowerLineSequenceOptions.pitch_jitter_deg", pitch_jitter_deg, "must be in [0, 5]");
  CheckOption(std::isfinite(roll_jitter_deg) && roll_jitter_deg >= 0 && roll_jitter_deg <= 5,
              "PowerLineSequenceOptions.roll_jitter_deg", roll_jitter_deg, "must be in [0, 5]");
  CheckOption(std::isfinite(bounce_m) && bounce_m >= 0 && bounce_m <= 0.05,
              "PowerLineSequenceOptions.bounce_m", bounce_m, "must be in [0, 0.05] m");
}

PowerLineSequence::PowerLineSequence(const PowerLineSequenceOptions& options) : options_(options) {
  options_.Check();
  detail::NoiseStream random(detail::Mix64(options.seed ^ 0x5e9e4ce5ULL));
  const std::vector<ObstacleType> types = AllObstacleTypes();
  double near_end = options.start_gap_m;
  for (int i = 0; i < options.num_obstacles; ++i) {
    const auto pick = std::min<size_t>(types.size() - 1, size_t(random.Uniform() * types.size()));
    const ObstacleType type = types[pick];
    const std::array<double, 2> extent = ObstacleAlongExtent(type);
    layout_.push_back({type, near_end - extent[0]});
    near_end += extent[1] - extent[0] + options.min_spacing_m +
                random.Uniform() * (options.max_spacing_m - options.min_spacing_m);
  }
  for (int i = 0; i < 6; ++i) phases_.push_back(2.0 * std::numbers::pi * random.Uniform());
  if (options.tilted_damper_share > 0) {
    detail::NoiseStream damage(detail::Mix64(options.seed ^ 0xda3a9edULL));
    for (SequenceLayoutEntry& entry : layout_) {
      if (entry.type != ObstacleType::kDamper) continue;
      const double pick = damage.Uniform(), size = damage.Uniform(), side = damage.Uniform();
      if (pick < options.tilted_damper_share) {
        entry.tilt_deg = (side < 0.5 ? -1.0 : 1.0) * (10.0 + 15.0 * size);
      }
    }
  }
  frames_ =
      1 + static_cast<int>(std::floor(
              (options.start_gap_m - options.end_gap_m) / options.speed_mps * options.fps + 1e-9));
  const double travelled = TravelledAt(frames_ - 1);
  CheckOption(options.scene.span_ahead_m - travelled >= 10.0,
              "PowerLineSequenceOptions.scene.span_ahead_m", options.scene.span_ahead_m,
              "must leave >= 10 m to the next tower at the end of the sequence");
  CheckOption(layout_.back().arc_m - travelled < 0.9 * (options.scene.span_ahead_m - travelled),
              "PowerLineSequenceOptions.num_obstacles", options.num_obstacles,
              "must fit before the next tower");
  if (options.num_defects > 0) {
    // A stream of its own: the obstacles and the motion are those of the sequence without defects.
    constexpr double kFirstDefectArc = 0.5;
    const double last_arc = layout_.back().arc_m;
    CheckOption(last_arc - kFirstDefectArc >= 0.5 * (options.num_defects - 1),
                "PowerLineSequenceOptions.num_defects", options.num_defects,
                "must fit 0.5 m apart between the robot's start and the last obstacle");
    defects_ = RandomDefects(detail::Mix64(options.seed ^ 0xdefec75e9ULL), options.num_defects,
                             kFirstDefectArc, last_arc);
  }
}

PowerLineSceneOptions PowerLineSequence::FrameOptions(int index) const {
  CheckOption(index >= 0 && index < frames_, "PowerLineSequence frame index", index,
              fmt::format("must be in [0, {})", frames_).c_str());
  const double t = TimestampOf(index);
  const double travelled = TravelledAt(index);
  auto wave = [&](int channel, double slow_hz, double fast_hz) {
    return 0.6 * std::sin(2 * std::numbers::pi * slow_hz * t + phases_[2 * channel]) +
           0.4 * std::sin(2 * std::numbers::pi * fast_hz * t + phases_[2 * channel + 1]);
  };
  PowerLineSceneOptions o = options_.scene;
  o.seed = options_.seed;
  o.sensor.noise_seed = detail::Mix64(options_.seed * 7919 + static_cast<std::uint64_t>(index));
  o.conductor_pitch_rad += options_.pitch_jitter_deg * kDegree * wave(0, kSwayHz, kVibrationHz);
  o.conductor_roll_rad += options_.roll_jitter_deg * kDegree * wave(1, kSwayHz * 0.8, kVibrationHz);
  o.conductor_offset_y_m += options_.bounce_m * wave(2, kBounceHz, kVibrationHz * 1.7);
  o.span_ahead_m -= travelled;
  o.obstacles.clear();
  for (const SequenceLayoutEntry& entry : layout_) {
    ObstacleSpec spec;
    spec.type = entry.type;
    spec.arc_m = entry.arc_m - travelled;
    spec.tilt_deg = entry.tilt_deg;
    o.obstacles.push_back(spec);
  }
  o.defects = defects_;
  for (DefectSpec& defect : o.defects) defect.arc_m -= travelled;
  return o;
}

PowerLineScene PowerLineSequence::Render(int index) const {
  return RenderPowerLineScene(FrameOptions(index));
}

nlohmann::json SequenceFrameTruthToJson(int index, double timestamp_s, double travelled_m,
                                        const PowerLineScene& scene) {
  nlohmann::json list = nlohmann::json::array();
  for (const RenderedObstacle& o : scene.obstacles) {
    nlohmann::json entry = {{"id", o.id},
                            {"type", ObstacleTypeName(o.type)},
                            {"arc_distance_m", o.near_arc_m},
                            {"box", {o.box.x, o.box.y, o.box.width, o.box.height}},
                            {"visible_pixels", o.visible_pixels}};
    entry["distance_m"] = std::isfinite(o.distance_m) ? nlohmann::json(o.distance_m) : nullptr;
    if (o.tilt_deg != 0) entry["tilt_deg"] = o.tilt_deg;
    list.push_back(entry);
  }
  nlohmann::json truth = {{"frame", index},
                          {"timestamp_s", timestamp_s},
                          {"travelled_m", travelled_m},
                          {"obstacles", list}};
  if (!scene.defects.empty()) {
    // The still scene's fields, its centre arc named as the distance along the line from the robot.
    nlohmann::json defects = DefectsToJson(scene.defects)["defects"];
    for (nlohmann::json& entry : defects) {
      entry["arc_distance_m"] = entry["arc_m"];
      entry.erase("arc_m");
    }
    truth["defects"] = defects;
  }
  return truth;
}

void WritePowerLineSequence(const std::filesystem::path& dir, const PowerLineSequence& sequence,
                            int max_frames, const std::function<void(int, int)>& progress) {
  CheckOption(max_frames >= 0, "max_frames", max_frames, "must be >= 0 (0 = all)");
  detail::CreateOutputDirectory(dir);
  const int count = max_frames == 0 ? sequence.size() : std::min(max_frames, sequence.size());
  std::string truth;
  for (int k = 0; k < count; ++k) {
    const PowerLineScene scene = sequence.Render(k);
    if (k == 0) WriteStereoCalibration(dir / "stereo.yml", scene.calibration);
    WriteImage(dir / fmt::format("left_{:04d}.png", k), scene.left);
    WriteImage(dir / fmt::format("right_{:04d}.png", k), scene.right);
    truth += SequenceFrameTruthToJson(k, sequence.TimestampOf(k), sequence.TravelledAt(k), scene)
                 .dump() +
             "\n";
    if (progress) progress(k + 1, count);
  }
  WriteTextAtomic(dir / "truth.jsonl", truth);
  const PowerLineSequenceOptions& o = sequence.options();
  nlohmann::json layout = nlohmann::json::array();
  for (const SequenceLayoutEntry& e : sequence.layout()) {
    layout.push_back({{"type", ObstacleTypeName(e.type)}, {"arc_m", e.arc_m}});
    if (e.tilt_deg != 0) layout.back()["tilt_deg"] = e.tilt_deg;
  }
  nlohmann::json description = {{"seed", o.seed},
                                {"frames", count},
                                {"fps", o.fps},
                                {"speed_mps", o.speed_mps},
                                {"start_gap_m", o.start_gap_m},
                                {"end_gap_m", o.end_gap_m},
                                {"pitch_jitter_deg", o.pitch_jitter_deg},
                                {"roll_jitter_deg", o.roll_jitter_deg},
                                {"bounce_m", o.bounce_m},
                                {"tilted_damper_share", o.tilted_damper_share},
                                {"supersampling", o.scene.sensor.supersampling},
                                {"layout", layout}};
  if (!sequence.defects().empty()) {
    nlohmann::json defects = nlohmann::json::array();
    for (const DefectSpec& d : sequence.defects()) {
      defects.push_back({{"type", DefectTypeName(d.type)},
                         {"arc_m", d.arc_m},
                         {"swelling", d.swelling},
                         {"length_m", d.length_m},
                         {"strands", d.strands},
                         {"standoff_m", d.standoff_m},
                         {"angle_deg", d.angle_deg}});
    }
    description["defects"] = defects;
  }
  WriteJson(dir / "sequence.json", description);
}

}  // namespace linesight::sim
