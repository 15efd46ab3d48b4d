// Ranging on rectified pairs made by other means than the power-line scene's ray caster: the
// ranging accuracy must hold on the textured plates and boxes of sim/plate_scene.h too.
//
// RunPlateStudy ranges every rendered pair through RangingPipeline with input_rectified (the
// chain of `linesight range --rectified --calib C --left L --right R --roi ...`) with the ROI the
// object's true box grown by 15 % + 6 px, so the wall behind is inside the ROI.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "linesight/io/stereo_calibration.h"
#include "linesight/ranging/pipeline.h"
#include "linesight/sim/plate_scene.h"

namespace linesight {

class ProgressBar;

struct PlateStudyOptions {
  sim::PlateRig rig;
  std::vector<sim::PlateShape> shapes{sim::PlateShape::kPlate, sim::PlateShape::kSlantedPlate,
                                      sim::PlateShape::kBox};
  // Photographs for the object's faces and for the wall, file names under texture_dir.
  std::filesystem::path texture_dir = "/usr/share/doc/opencv-doc/examples/data";
  std::vector<std::string> textures{"baboon.jpg", "graf1.png", "fruits.jpg"};
  std::string background = "leuvenA.jpg";
  std::vector<double> distances{0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 4.5, 5.0};
  int runs = 10;          // captures per scene, fresh read noise each
  double noise_dn = 1.0;  // read noise (DN)
  int supersampling = 3;
  std::uint64_t seed = 1;           // noise seeds derive from it
  RangingPipelineOptions pipeline;  // input_rectified is forced on
  std::filesystem::path save_dir;   // if set: first capture of each scene as left/right PNG,
                                    // calib.yml and scene.json (true distance, ROI)

  void Check() const;
};

struct PlateCell : RangeRunStats {
  std::string shape, texture;
  double truth_m = 0.0;
  double relative_error() const { return measured > 0 ? (mean_m - truth_m) / truth_m : 0.0; }
};

struct PlateStudyReport {
  std::string method, command, machine, background;
  sim::PlateRig rig;
  int runs = 0;
  double noise_dn = 0.0, elapsed_s = 0.0;
  nlohmann::json ranging_settings;  // every --ranging setting the chain ran with
  std::vector<PlateCell> cells;

  std::string ToMarkdown() const;
  nlohmann::json ToJson() const;
  // plates.svg: relative error vs distance, one panel per shape, one series per texture.
  void WritePlots(const std::filesystem::path& dir) const;
};

// Throws InputError when a texture cannot be read (naming the file).
PlateStudyReport RunPlateStudy(const PlateStudyOptions& options, ProgressBar* progress = nullptr);

}  // namespace linesight
