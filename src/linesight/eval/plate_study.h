// Ranging on rectified pairs made by other means than the power-line scene's ray caster: the
// ranging accuracy must hold on rectified pairs rendered by other means.
//
// RenderPlateScene is a small renderer of its own, independent of src/linesight/sim: textured
// planar faces (a plate, a plate turned about its vertical axis, or a box) in front of a textured
// wall, seen by an ideal rectified rig. Textures are photographs (OpenCV's sample images),
// mip-mapped and sampled trilinearly at each sub-sample's footprint; each pixel averages
// supersampling² rays (box filter, like a sensor's fill factor). Nothing of the power-line
// scene's procedural textures, shading or sensor model is used, so a bias that the two share
// comes from the matcher or the estimator, not from one renderer.
//
// Ground truth: the depth Z of the nearest hit of each pixel-centre ray (rectified left camera
// frame); the object's true distance is the minimum Z over the pixels that show it, as for the
// power-line obstacles (the nearest surface along the optical axis).
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

namespace linesight {

class ProgressBar;

// An ideal rectified rig (no distortion, parallel cameras, right camera at +baseline along x).
struct PlateRig {
  cv::Size image_size{752, 480};  // MYNT S1030 by default
  double focal_px = 736.0;
  double baseline_m = 0.119;

  void Check() const;
  // M1 = M2, zero distortion, R = R1 = R2 = I, T = (-B, 0, 0), P1, P2 and Q of the rectified pair.
  StereoCalibration Calibration() const;
};

enum class PlateShape {
  kPlate,         // fronto-parallel rectangle
  kSlantedPlate,  // the rectangle turned about its vertical axis; its near edge at distance_m
  kBox,           // cuboid: front face at distance_m, sides and top visible off the axis
};
std::string PlateShapeName(PlateShape shape);
// "plate", "slanted", "box"; UsageError otherwise.
PlateShape ParsePlateShape(const std::string& text);

struct PlateSceneSpec {
  PlateRig rig;
  PlateShape shape = PlateShape::kPlate;
  double distance_m = 2.0;              // depth of the object's nearest point
  cv::Point2d centre_px{300.0, 200.0};  // where the front face's centre projects (left image)
  cv::Size2d size_m{0.24, 0.16};        // plate / box front face, width x height (m)
  double box_depth_m = 0.25;            // box: extent along the optical axis
  double slant_rad = 0.6;               // slanted plate: rotation about the vertical axis
  double background_m = 0.0;            // wall depth; 0 = 1.5 * distance_m + 1 m
  cv::Mat plate_texture;                // 8-bit BGR or grey photograph (required)
  cv::Mat background_texture;           // 8-bit BGR or grey photograph (required)
  int supersampling = 3;                // rays per pixel side

  void Check() const;
};

// Noise-free radiance (CV_32FC3 in [0, 1]) of both views and the left view's ground truth.
struct PlateRendering {
  cv::Mat left, right;
  cv::Mat depth_gt;         // CV_32FC1, Z of the pixel-centre ray's hit (m)
  cv::Mat disparity_gt;     // CV_32FC1, f * B / Z (px)
  cv::Mat object_mask;      // CV_8UC1, 255 where the pixel centre sees the object
  double distance_m = 0.0;  // minimum depth_gt over object_mask
  cv::Rect box;             // bounding box of object_mask
};

PlateRendering RenderPlateScene(const PlateSceneSpec& spec);

// 8-bit BGR image of a radiance image: Gaussian read noise of `noise_dn` (seeded) and rounding.
cv::Mat CapturePlateImage(const cv::Mat& radiance, double noise_dn, std::uint64_t seed);

struct PlateStudyOptions {
  PlateRig rig;
  std::vector<PlateShape> shapes{PlateShape::kPlate, PlateShape::kSlantedPlate, PlateShape::kBox};
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
  PlateRig rig;
  int runs = 0;
  double noise_dn = 0.0, elapsed_s = 0.0;
  std::vector<PlateCell> cells;

  std::string ToMarkdown() const;
  nlohmann::json ToJson() const;
  // plates.svg: relative error vs distance, one panel per shape, one series per texture.
  void WritePlots(const std::filesystem::path& dir) const;
};

// Throws InputError when a texture cannot be read (naming the file).
PlateStudyReport RunPlateStudy(const PlateStudyOptions& options, ProgressBar* progress = nullptr);

}  // namespace linesight
