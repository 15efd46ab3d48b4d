// `linesight demo`: the whole chain on the embedded synthetic power-line scene. Render calibration
// boards and the scene with exact ground truth, calibrate from the boards, rectify, match, range
// every obstacle, and compare the measured distances with the true ones.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "linesight/sim/power_line_scene.h"

namespace linesight {

struct DemoOptions {
  std::filesystem::path out_dir = "out";  // images, stereo.yml, cloud.ply, report.json go here
  std::uint64_t seed = 1;                 // scene and board seed
  // Obstacles on the line (type:distance_m, see sim::ParseObstacleSpecs).
  std::vector<sim::ObstacleSpec> obstacles = sim::PowerLineSceneOptions().obstacles;
  std::string method;                        // matcher; empty = DefaultMatcherName()
  std::string calibration_method = "zhang";  // zhang | recon | opencv
  int board_views = 15;                      // rendered calibration views
  bool use_true_calibration = false;  // skip calibration, range with the renderer's calibration
  double min_depth_m = 0.3;           // working range of the matcher (m)
  double max_depth_m = 6.0;
  int threads = 0;  // matcher threads, 0 = all cores

  void Check() const;
};

struct DemoObstacleRow {
  std::string type;
  double true_distance_m = 0;
  bool measured = false;
  std::string reason;     // when not measured
  double distance_m = 0;  // ranged in the (dilated) true box
  double sigma_m = 0;
  double error_percent = 0;    // 100 * (measured - true) / true
  bool auto_found = false;     // the automatic finder found a region overlapping the obstacle
  double auto_distance_m = 0;  // its distance
};

struct DemoReport {
  std::vector<DemoObstacleRow> rows;
  nlohmann::json json;  // everything, as written to report.json
  // Markdown table: obstacle | true | measured ± sigma | error % | auto.
  std::string Table() const;
};

// Runs the demo and writes its outputs into options.out_dir (created if missing). Progress (one
// line per stage) goes to `log` when non-null.
DemoReport RunDemo(const DemoOptions& options, std::FILE* log = nullptr);

}  // namespace linesight
