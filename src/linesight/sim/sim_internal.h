// Internal to the sim module: pieces shared by the power-line scene and the calibration boards.
#pragma once

#include <array>
#include <filesystem>
#include <vector>

#include <opencv2/core.hpp>

#include "linesight/io/stereo_calibration.h"
#include "linesight/sim/camera_model.h"
#include "linesight/sim/power_line_scene.h"
#include "linesight/sim/scene_render.h"

namespace linesight::sim::detail {

inline constexpr const char* kDistanceDefinition =
    "distance_m is the distance from the left camera centre to the obstacle's nearest surface as "
    "seen, along the rectified left optical axis: the minimum ground-truth depth Z over the "
    "obstacle's visible pixels in the rectified left image";

struct RigPoses {
  PosedCamera left, right;                      // raw cameras
  PosedCamera rectified_left, rectified_right;  // rectified cameras (orientation R1 * left)
};

Mat3 FromCv(const cv::Matx33d& m);
Mat3 Multiply(const Mat3& a, const Mat3& b);
// Pinhole intrinsics of the rectified cameras (from P1).
CameraIntrinsics RectifiedIntrinsics(const StereoCalibration& calib);
// Poses of all four cameras in a world frame given the left camera's orientation in it (the left
// camera centre is the world origin).
RigPoses MakeRigPoses(const StereoCalibration& calib, const Mat3& left_from_world);

// The geometry of a power-line scene with its obstacles placed, ready to render (world frame:
// origin at the left camera centre, y along gravity).
struct PowerLineSceneModel {
  StereoCalibration calibration;
  RigPoses poses;
  RenderScene scene;
  std::vector<double> surface_min_depth;  // per obstacle spec: min Z_rect over its surface
  std::vector<double> arc;                // per obstacle spec: arc length of its centre (m)
  // Per defect spec: arc of its surface's near and far end along the line (m, DefectSpec::arc_m's
  // origin).
  std::vector<std::array<double, 2>> defect_extent;
  std::vector<ConductorAxisPoint> conductor_axis;  // conductor 0, rectified left frame
};
PowerLineSceneModel BuildPowerLineSceneModel(const PowerLineSceneOptions& options);

// Creates `dir` (and parents) or throws InputError naming it.
void CreateOutputDirectory(const std::filesystem::path& dir);

}  // namespace linesight::sim::detail
