// A moving synthetic power-line sequence: the robot rides along conductor 0 toward the obstacles
// on it at a set speed, with the sway and vibration of a line robot, and every frame comes with
// exact ground truth.
//
// The obstacles are fixed on the line at arc positions drawn from the seed (types, gaps); the
// robot starts with the near end of the first obstacle `start_gap_m` of arc ahead and the sequence
// ends when it is `end_gap_m` ahead. Frame k is the power-line scene (power_line_scene.h) seen
// from the robot's position at t = k / fps: every obstacle's arc is its layout arc minus the
// distance travelled, the span to the next tower shrinks by the same amount, and the rig pitches,
// rolls and bounces by smooth seeded oscillations (a slow sway and a faster vibration). Frames
// are independent of each other (any frame renders alone, in any order, to the same bytes).
//
// Optionally, defects of conductor 0 (a birdcage, broken strands, a hanging string, a plastic
// sheet, a nest; power_line_scene.h) are fixed on the line too, drawn from a seed derived from the
// sequence's seed (so the obstacles and the motion do not depend on them) between the robot's
// start and the last obstacle; they move through the frames like the obstacles.
//
// Truth per frame (PowerLineScene::obstacles): each obstacle's type, near-end arc length from
// the robot (`near_arc_m`, the distance along the line the robot travels before it reaches it),
// straight distance (`distance_m`, the nearest visible surface along the rectified optical axis,
// +inf when not in view), box and mask; the conductor's axis (`conductor_axis`); and each defect's
// arc, extent, size, nearest visible depth, box and mask (PowerLineScene::defects).
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <vector>

#include <nlohmann/json.hpp>

#include "linesight/sim/power_line_scene.h"

namespace linesight::sim {

struct PowerLineSequenceOptions {
  // Rig, sensor, line and background of every frame; its obstacles, seed and the jittered pose
  // fields (pitch, roll, y offset, span) are set per frame. Supersampling 1 renders a 752x480
  // frame in about 0.3 s on 2 cores; the default 2 is smoother.
  PowerLineSceneOptions scene;
  std::uint64_t seed = 1;  // obstacle layout, motion jitter, textures and noise
  double fps = 10.0;       // frame rate of the timestamps (Hz), 0.5..120
  double speed_mps = 0.3;  // robot speed along the line (m/s), 0.02..3
  // Arc length from the robot to the near end of the first obstacle at the first frame and at the
  // last one (m): the sequence has floor((start - end) / speed * fps) + 1 frames.
  double start_gap_m = 6.0;
  double end_gap_m = 0.4;
  int num_obstacles = 3;  // 1..6, types drawn from the seed (damper, clamp, insulator)
  // Defects on conductor 0, 0..6: types, sizes and arcs (0.5 m apart, from 0.5 m ahead of the
  // robot's start to the centre of the last obstacle) drawn by RandomDefects from a seed derived
  // from `seed`.
  int num_defects = 0;
  // Share of the dampers (0..1) that are damaged: turned about the line by 10..25 deg to either
  // side (ObstacleSpec::tilt_deg), drawn from a seed derived from `seed` (so the layout, the motion
  // and the defects do not depend on it).
  double tilted_damper_share = 0.0;
  // Clear arc between one obstacle's far end and the next one's near end (m), drawn uniformly.
  double min_spacing_m = 1.0;
  double max_spacing_m = 2.5;
  // Motion of the rig: peak pitch and roll (deg) and vertical bounce (m).
  double pitch_jitter_deg = 0.3;
  double roll_jitter_deg = 0.3;
  double bounce_m = 0.004;

  void Check() const;  // OptionError naming the field
};

struct SequenceLayoutEntry {
  ObstacleType type = ObstacleType::kDamper;
  double arc_m = 0.0;     // arc of its centre from the robot's START position (m)
  double tilt_deg = 0.0;  // a damaged damper's tilt (ObstacleSpec::tilt_deg)
};

class PowerLineSequence {
 public:
  explicit PowerLineSequence(const PowerLineSequenceOptions& options);

  int size() const { return frames_; }
  double TimestampOf(int index) const { return index / options_.fps; }
  // Distance the robot has travelled along the line at frame `index` (m).
  double TravelledAt(int index) const { return options_.speed_mps * TimestampOf(index); }
  const std::vector<SequenceLayoutEntry>& layout() const { return layout_; }
  // The defects with their arcs from the robot's START position (m); empty without num_defects.
  const std::vector<DefectSpec>& defects() const { return defects_; }
  const PowerLineSequenceOptions& options() const { return options_; }

  // The scene options of frame `index` (0 <= index < size()).
  PowerLineSceneOptions FrameOptions(int index) const;
  // Renders frame `index` (raw pair, true calibration, ground truth); fresh sensor noise per frame.
  PowerLineScene Render(int index) const;

 private:
  PowerLineSequenceOptions options_;
  std::vector<SequenceLayoutEntry> layout_;
  std::vector<DefectSpec> defects_;
  std::vector<double> phases_;  // of the motion oscillations
  int frames_ = 0;
};

// Truth of one frame as JSON: {"frame", "timestamp_s", "travelled_m", "obstacles": [{"id",
// "type", "arc_distance_m" (near end), "distance_m" (straight, null when not visible), "box",
// "visible_pixels", and "tilt_deg" for a tilted damper}]}, and when the scene has defects
// "defects": [{"id", "type", "arc_distance_m" (centre, from the robot), "arc_begin_m", "arc_end_m"
// (its extent, from the robot), "size_m", "distance_m" (null when not visible), "box",
// "visible_pixels"}].
nlohmann::json SequenceFrameTruthToJson(int index, double timestamp_s, double travelled_m,
                                        const PowerLineScene& scene);

// Writes the sequence into `dir`: stereo.yml (the true calibration), left_NNNN.png and
// right_NNNN.png per frame (a pair `--source images:DIR/left_*.png,DIR/right_*.png` replays),
// truth.jsonl (one SequenceFrameTruthToJson line per frame) and sequence.json (options, layout
// and, when there are defects, the defects). Writes the first `max_frames` frames (0 = all).
// `progress(done, total)` is called after every frame.
void WritePowerLineSequence(const std::filesystem::path& dir, const PowerLineSequence& sequence,
                            int max_frames = 0, const std::function<void(int, int)>& progress = {});

}  // namespace linesight::sim
