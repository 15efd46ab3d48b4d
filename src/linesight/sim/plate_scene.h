// Textured planar objects at known depths for an ideal rectified rig: a small renderer of its own,
// independent of the power-line scene's ray caster (scene_render, power_line_scene): textured
// planar faces (a plate, a plate turned about its vertical axis, or a box) in front of a textured
// wall. Textures are photographs (OpenCV's sample images), mip-mapped and sampled trilinearly at
// each sub-sample's footprint; each pixel averages supersampling² rays (box filter, like a
// sensor's fill factor). Nothing of the power-line scene's procedural textures, shading or sensor
// model is used, so a bias that the two share comes from the matcher or the estimator, not from
// one renderer (eval/plate_study.h ranges these scenes).
//
// Ground truth: the depth Z of the nearest hit of each pixel-centre ray (rectified left camera
// frame); the object's true distance is the minimum Z over the pixels that show it, as for the
// power-line obstacles (the nearest surface along the optical axis).
#pragma once

#include <cstdint>
#include <string>

#include <opencv2/core.hpp>

#include "linesight/io/stereo_calibration.h"

namespace linesight::sim {

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

}  // namespace linesight::sim
