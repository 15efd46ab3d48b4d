// Obstacle images: the matcher comparison on synthetic power-line obstacles —
// Stockbridge damper (counterweight), suspension clamp, insulator string — rendered by
// sim::RenderPowerLineScene as an ideal rectified pair with exact ground truth, each cropped to
// its obstacle.
//
// The crop: the obstacle's bounding box (visible pixels of the rectified left image) grown by a
// margin is the EVALUATION box. The stereo pair handed to a matcher spans the same rows and the
// evaluation box's columns extended to the left by the search range (clipped at the image border),
// so every true match of an evaluated pixel lies inside the right crop, and disparities in the
// crop equal those of the full image. Ground truth is the full ground truth at the crop's offset.
// Regions (masks over the crop): "obstacle" = the obstacle's own pixels with known ground truth,
// "all" = every pixel of the evaluation box with known ground truth (conductor, towers, ground
// behind it; sky has no ground truth). There is no occlusion mask: occluded pixels are evaluated.
// The search range of a crop: a multiple of 16 >= ceil(1.1 * max ground truth in the evaluation
// box) + 1, min disparity 0.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "linesight/eval/dataset.h"
#include "linesight/eval/eval_stereo.h"
#include "linesight/eval/noise.h"
#include "linesight/sim/power_line_scene.h"

namespace linesight {

class ProgressBar;

// Set name of the obstacle scenes in reports.
inline constexpr char kObstacleSetName[] = "synthetic-obstacles";

// Crops one obstacle out of a rectified pair (see the file comment). `left`, `right`: rectified
// images of one size; `ground_truth`: CV_32FC1 left disparity (+inf unknown); `obstacle_mask`:
// CV_8UC1 ids; `box`: the obstacle's bounding box in the full image. Returns a StereoScene with
// ref.set = kObstacleSetName and ref.name = `name`. Throws InputError for mismatched sizes or a
// box outside the image.
StereoScene CropObstacleScene(const cv::Mat& left, const cv::Mat& right,
                              const cv::Mat& ground_truth, const cv::Mat& obstacle_mask,
                              int obstacle_id, const cv::Rect& box, int margin_px,
                              const std::string& name);

// Where the crop of CropObstacleScene lies in the full image (for tests and figures).
struct ObstacleCropGeometry {
  cv::Rect evaluation_box;  // box grown by the margin, clipped to the image
  cv::Rect crop;            // evaluation box extended to the left by the search range, clipped
  int num_disparities = 16;
};
ObstacleCropGeometry ObstacleCropFor(const cv::Mat& ground_truth, const cv::Rect& box,
                                     int margin_px);

struct ObstacleImageOptions {
  // Obstacles rendered into one power-line scene (type, distance in m along the line of sight).
  std::vector<sim::ObstacleSpec> obstacles{{sim::ObstacleType::kDamper, 1.5, 0},
                                           {sim::ObstacleType::kSuspensionClamp, 3.0, 0},
                                           {sim::ObstacleType::kInsulatorString, 4.5, 0}};
  std::uint64_t seed = 1;  // scene seed (textures, sensor noise)
  int supersampling = 3;   // anti-aliasing rays per pixel side, 1..8
  int margin_px = 12;      // margin around each obstacle's box (px), >= 0

  void Check() const;
};

// Renders the scene (ideal rectified pair) and returns one cropped StereoScene per obstacle, named
// "<type>@<distance>m" (e.g. "damper@1.5m").
std::vector<StereoScene> RenderObstacleScenes(const ObstacleImageOptions& options);

struct EvalObstaclesOptions {
  std::vector<std::string> methods = {"isgm", "sgm", "sgbm", "sgbm-wls", "bm"};
  std::map<std::string, std::string> params;  // as EvalStereoOptions::params
  std::vector<NoiseSpec> noise = {NoiseSpec()};
  uint64_t noise_seed = 1;
  int threads = 0;

  void Check() const;
};

struct EvalObstaclesReport {
  // set = kObstacleSetName, scene = crop name, regions "obstacle" and "all".
  std::vector<EvalStereoResult> results;
  nlohmann::json ToJson() const;
  // Per noise setting: rows obstacle x method with bad-1/bad-2/RMSE/density on the obstacle pixels
  // and bad-1/RMSE on the crop; then a method x noise table of the mean obstacle bad-1.
  std::string ToMarkdown() const;
  // <dir>/obstacles_noise.svg (mean obstacle bad-1 vs noise per method) when several noise
  // settings ran; returns the written names.
  std::vector<std::string> WritePlots(const std::filesystem::path& dir) const;
};

// Runs every method at every noise setting on every scene (noise seeded like RunEvalStereo).
EvalObstaclesReport RunEvalObstacles(const std::vector<StereoScene>& scenes,
                                     const EvalObstaclesOptions& options,
                                     ProgressBar* progress = nullptr);

}  // namespace linesight
