// Rendering of a power-line scene (PowerLineSceneRenderer, RenderPowerLineScene): ground truth
// (obstacles and defects) and radiance of the laid-out scene (power_line_layout.cc), the sensor
// model per capture, and the scene's files.
#include "linesight/sim/power_line_scene.h"

#include <cmath>
#include <filesystem>
#include <memory>
#include <system_error>
#include <utility>

#include <fmt/format.h>

#include "linesight/core/disparity.h"
#include "linesight/core/error.h"
#include "linesight/io/image_io.h"
#include "linesight/io/json_io.h"
#include "linesight/io/pfm.h"
#include "linesight/sim/power_line_internal.h"
#include "linesight/sim/procedural_texture.h"
#include "linesight/sim/scene_render.h"
#include "linesight/sim/sensor_model.h"
#include "linesight/sim/sim_internal.h"

namespace linesight::sim {

using detail::MeasureVisible;
using detail::VisibleStats;

namespace detail {

void CreateOutputDirectory(const std::filesystem::path& dir) {
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  if (error || !std::filesystem::is_directory(dir)) {
    throw InputError(fmt::format("cannot create output folder '{}': {}", dir.string(),
                                 error ? error.message() : "not a directory"));
  }
}

}  // namespace detail

struct PowerLineSceneRenderer::Linear {
  cv::Mat left, right, rectified_left, rectified_right;  // CV_32FC3 radiance
  CameraIntrinsics rectified;
};

PowerLineSceneRenderer::PowerLineSceneRenderer(const PowerLineSceneOptions& options)
    : options_(options), linear_(std::make_shared<Linear>()) {
  const detail::PowerLineSceneModel model = detail::BuildPowerLineSceneModel(options);
  const detail::RenderScene& scene = model.scene;
  const detail::RigPoses& poses = model.poses;
  PowerLineScene result;
  result.calibration = model.calibration;
  const cv::Size size = options.rig.image_size;
  const CameraIntrinsics rect_k = detail::RectifiedIntrinsics(result.calibration);

  cv::Mat depth, surface_class, ids, defect_ids;
  detail::TraceGroundTruth(scene, rect_k, poses.rectified_left, size,
                           cv::Rect(0, 0, size.width, size.height), &depth, &surface_class, &ids,
                           &defect_ids);
  const double focal_baseline = result.calibration.RectifiedFocal() * result.calibration.Baseline();
  cv::Mat disparity(size, CV_32FC1);
  for (int v = 0; v < size.height; ++v) {
    const auto* z = depth.ptr<float>(v);
    auto* d = disparity.ptr<float>(v);
    for (int u = 0; u < size.width; ++u) {
      d[u] = std::isfinite(z[u]) ? static_cast<float>(focal_baseline / z[u]) : kInvalidDisparity;
    }
  }
  result.depth = depth;
  result.disparity = disparity;
  result.surface_class = surface_class;
  result.obstacle_mask = ids;
  result.conductor_axis = model.conductor_axis;
  for (size_t i = 0; i < options.obstacles.size(); ++i) {
    const int id = static_cast<int>(i) + 1;
    const VisibleStats stats =
        MeasureVisible(depth, ids, id, cv::Rect(0, 0, size.width, size.height));
    RenderedObstacle o;
    o.id = id;
    o.type = options.obstacles[i].type;
    o.conductor = options.obstacles[i].conductor;
    o.requested_distance_m = options.obstacles[i].distance_m;
    o.distance_m = stats.min_depth;
    o.surface_min_depth_m = model.surface_min_depth[i];
    o.nearest_pixel = stats.nearest;
    o.box = stats.box;
    o.visible_pixels = stats.pixels;
    o.arc_m = model.arc[i];
    o.near_arc_m = o.arc_m + ObstacleAlongExtent(o.type)[0];
    o.tilt_deg = options.obstacles[i].tilt_deg;
    result.obstacles.push_back(o);
  }
  result.defect_mask = defect_ids;
  for (size_t i = 0; i < options.defects.size(); ++i) {
    const DefectSpec& spec = options.defects[i];
    const int id = static_cast<int>(i) + 1;
    const VisibleStats stats =
        MeasureVisible(depth, defect_ids, id, cv::Rect(0, 0, size.width, size.height));
    RenderedDefect d;
    d.id = id;
    d.type = spec.type;
    d.arc_m = spec.arc_m;
    d.arc_begin_m = model.defect_extent[i][0];
    d.arc_end_m = model.defect_extent[i][1];
    d.size_m = detail::DefectSize(spec, options.conductor_radius_m);
    d.distance_m = stats.min_depth;
    d.box = stats.box;
    d.visible_pixels = stats.pixels;
    result.defects.push_back(d);
  }

  // Radiance through the distorted raw cameras (and the ideal rectified ones); the sensor model is
  // applied per capture.
  const int supersampling = options.sensor.supersampling;
  linear_->left =
      detail::RenderLinearImage(scene, options.rig.left, poses.left, size, supersampling);
  linear_->right =
      detail::RenderLinearImage(scene, options.rig.right, poses.right, size, supersampling);
  linear_->rectified = rect_k;
  if (options.render_rectified_pair) {
    linear_->rectified_left =
        detail::RenderLinearImage(scene, rect_k, poses.rectified_left, size, supersampling);
    linear_->rectified_right =
        detail::RenderLinearImage(scene, rect_k, poses.rectified_right, size, supersampling);
  }
  ground_truth_ = std::move(result);
}

std::uint64_t PowerLineSceneRenderer::DefaultNoiseSeed() const {
  return options_.sensor.noise_seed.value_or(detail::Mix64(options_.seed ^ 0xa5a5a5a5ULL));
}

PowerLineScene PowerLineSceneRenderer::Capture(std::uint64_t noise_seed) const {
  PowerLineScene result = ground_truth_;
  const SensorOptions& sensor = options_.sensor;
  const StereoRigOptions& rig = options_.rig;
  result.left = detail::EncodeSensorImage(linear_->left, sensor, 1.0, rig.left.cx, rig.left.cy,
                                          detail::Mix64(noise_seed * 2 + 1));
  result.right = detail::EncodeSensorImage(linear_->right, sensor, sensor.right_gain, rig.right.cx,
                                           rig.right.cy, detail::Mix64(noise_seed * 2 + 2));
  if (options_.render_rectified_pair) {
    const CameraIntrinsics& k = linear_->rectified;
    result.rectified_left = detail::EncodeSensorImage(linear_->rectified_left, sensor, 1.0, k.cx,
                                                      k.cy, detail::Mix64(noise_seed * 2 + 3));
    result.rectified_right =
        detail::EncodeSensorImage(linear_->rectified_right, sensor, sensor.right_gain, k.cx, k.cy,
                                  detail::Mix64(noise_seed * 2 + 4));
  }
  return result;
}

PowerLineScene RenderPowerLineScene(const PowerLineSceneOptions& options) {
  const PowerLineSceneRenderer renderer(options);
  return renderer.Capture(renderer.DefaultNoiseSeed());
}

nlohmann::json ObstaclesToJson(const std::vector<RenderedObstacle>& obstacles) {
  nlohmann::json list = nlohmann::json::array();
  for (const RenderedObstacle& o : obstacles) {
    list.push_back({{"id", o.id},
                    {"type", ObstacleTypeName(o.type)},
                    {"conductor", o.conductor},
                    {"requested_distance_m", o.requested_distance_m},
                    {"distance_m", o.distance_m},
                    {"surface_min_depth_m", o.surface_min_depth_m},
                    {"nearest_pixel", {o.nearest_pixel.x, o.nearest_pixel.y}},
                    {"box", {o.box.x, o.box.y, o.box.width, o.box.height}},
                    {"visible_pixels", o.visible_pixels},
                    {"arc_m", o.arc_m},
                    {"near_arc_m", o.near_arc_m},
                    {"tilt_deg", o.tilt_deg}});
  }
  return {{"distance_definition", detail::kDistanceDefinition}, {"obstacles", list}};
}

nlohmann::json DefectsToJson(const std::vector<RenderedDefect>& defects) {
  nlohmann::json list = nlohmann::json::array();
  for (const RenderedDefect& d : defects) {
    nlohmann::json entry = {{"id", d.id},
                            {"type", DefectTypeName(d.type)},
                            {"arc_m", d.arc_m},
                            {"arc_begin_m", d.arc_begin_m},
                            {"arc_end_m", d.arc_end_m},
                            {"size_m", d.size_m},
                            {"box", {d.box.x, d.box.y, d.box.width, d.box.height}},
                            {"visible_pixels", d.visible_pixels}};
    entry["distance_m"] = std::isfinite(d.distance_m) ? nlohmann::json(d.distance_m) : nullptr;
    list.push_back(entry);
  }
  return {{"defects", list}};
}

void WritePowerLineScene(const std::filesystem::path& dir, const PowerLineScene& scene) {
  detail::CreateOutputDirectory(dir);
  WriteImage(dir / "left.png", scene.left);
  WriteImage(dir / "right.png", scene.right);
  WriteStereoCalibration(dir / "stereo.yml", scene.calibration);
  WritePfm(dir / "disparity_gt.pfm", scene.disparity);
  WritePfm(dir / "depth_gt.pfm", scene.depth);
  WriteImage(dir / "obstacle_mask.png", scene.obstacle_mask);
  WriteImage(dir / "surface_class.png", scene.surface_class);
  WriteJson(dir / "obstacles.json", ObstaclesToJson(scene.obstacles));
  if (!scene.defects.empty()) {
    WriteJson(dir / "defects.json", DefectsToJson(scene.defects));
    WriteImage(dir / "defect_mask.png", scene.defect_mask);
  }
  if (!scene.rectified_left.empty()) {
    WriteImage(dir / "rectified_left.png", scene.rectified_left);
    WriteImage(dir / "rectified_right.png", scene.rectified_right);
  }
}

}  // namespace linesight::sim