// Layout of a power-line scene (detail::BuildPowerLineSceneModel): the catenary conductors, the
// lattice towers, the lighting, the defects on conductor 0, and the placement of every obstacle at
// its requested distance as seen by the rectified left camera.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <numeric>
#include <vector>

#include <fmt/format.h>

#include "linesight/core/error.h"
#include "linesight/sim/camera_model.h"
#include "linesight/sim/power_line_internal.h"
#include "linesight/sim/power_line_scene.h"
#include "linesight/sim/procedural_texture.h"
#include "linesight/sim/scene_render.h"
#include "linesight/sim/sim_internal.h"

namespace linesight::sim {

using detail::Mat3;
using detail::Vec3;

namespace {

using detail::AddObstacle;
using detail::Cable;
using detail::kClassConductor;
using detail::kClassGround;
using detail::kClassTower;
using detail::LocalFrame;
using detail::MakeCapsule;
using detail::Material;
using detail::MeasureVisible;
using detail::Shape;
using detail::Tagged;

Mat3 RotationX(double a) {
  return {{1, 0, 0}, {0, std::cos(a), -std::sin(a)}, {0, std::sin(a), std::cos(a)}};
}
Mat3 RotationY(double a) {
  return {{std::cos(a), 0, std::sin(a)}, {0, 1, 0}, {-std::sin(a), 0, std::cos(a)}};
}
Mat3 RotationZ(double a) {
  return {{std::cos(a), -std::sin(a), 0}, {std::sin(a), std::cos(a), 0}, {0, 0, 1}};
}

// The world frame: origin at the left camera centre, y down along gravity, z horizontal along the
// line. Conductor c follows a catenary whose lowest point is half-way to the next tower.
class LineGeometry {
 public:
  explicit LineGeometry(const PowerLineSceneOptions& o) : o_(o) {
    a_ = o.sag_parameter_m;
    h_low_ = 0.5 * o.span_ahead_m;
    // Slope of the conductor at the camera (descending towards the lowest point).
    const double beta = std::atan(std::sinh(h_low_ / a_));
    left_from_world_ =
        detail::Multiply(RotationY(o.conductor_yaw_rad), RotationX(beta + o.conductor_pitch_rad));
    if (o.conductor_roll_rad != 0.0) {
      left_from_world_ = detail::Multiply(RotationZ(o.conductor_roll_rad), left_from_world_);
    }
    origin0_ =
        left_from_world_.ApplyTransposed({o.conductor_offset_x_m, o.conductor_offset_y_m, 0.0});
  }
  const Mat3& left_from_world() const { return left_from_world_; }

  // Horizontal distance h -> point on conductor c (world frame).
  Vec3 Point(int c, double h) const {
    const double sag = a_ * (std::cosh(h_low_ / a_) - std::cosh((h - h_low_) / a_));
    return origin0_ + Vec3{c * o_.conductor_spacing_m, sag, h};
  }
  Vec3 Tangent(double h) const {
    return detail::Normalized({0.0, -std::sinh((h - h_low_) / a_), 1.0});
  }
  // Arc length from h = 0 and its inverse.
  double Arc(double h) const {
    return a_ * (std::sinh((h - h_low_) / a_) + std::sinh(h_low_ / a_));
  }
  double HorizontalAt(double arc) const {
    return h_low_ + a_ * std::asinh(arc / a_ - std::sinh(h_low_ / a_));
  }
  double span() const { return o_.span_ahead_m; }

 private:
  const PowerLineSceneOptions& o_;
  double a_ = 0, h_low_ = 0;
  Mat3 left_from_world_;
  Vec3 origin0_;
};

// `f` turned about its along axis by `tilt_deg` (deg): > 0 swings "down" towards -side, i.e. to
// +x of the camera for a line that runs away from it.
LocalFrame Tilted(LocalFrame f, double tilt_deg) {
  if (tilt_deg == 0.0) return f;
  const double t = tilt_deg * std::numbers::pi / 180.0;
  const Vec3 down = std::cos(t) * f.down - std::sin(t) * f.side;
  f.down = down;
  f.side = Cross(f.along, f.down);
  return f;
}

LocalFrame FrameOnConductor(const LineGeometry& line, int conductor, double arc) {
  const double h = line.HorizontalAt(arc);
  LocalFrame f;
  f.origin = line.Point(conductor, h);
  f.along = line.Tangent(h);
  const Vec3 gravity{0, 1, 0};
  f.down = detail::Normalized(gravity - Dot(gravity, f.along) * f.along);
  f.side = Cross(f.along, f.down);
  return f;
}

void AddConductors(const PowerLineSceneOptions& o, const LineGeometry& line,
                   std::vector<Shape>* shapes) {
  for (int c = 0; c < o.num_conductors; ++c) {
    double h = -0.6;
    Vec3 previous = line.Point(c, h);
    double arc = line.Arc(h);
    while (h < line.span()) {
      // Segments grow with distance: the chord error against the catenary stays < 1 um near the
      // camera (where it could be seen) and the joints are spheres, so the tube has no gaps.
      const double step = std::min(0.08 + 0.06 * std::fabs(h), 6.0);
      const double next_h = std::min(h + step, line.span());
      const Vec3 next = line.Point(c, next_h);
      Shape s = Cable(MakeCapsule(previous, next, o.conductor_radius_m), arc);
      shapes->push_back(Tagged(s, Material::kConductor, kClassConductor, 0, 0.0));
      arc += detail::Norm(next - previous);
      previous = next;
      h = next_h;
    }
  }
}

// Square lattice tower standing on the ground at `base` (world), `height` tall, with a crossarm
// across the line at `crossarm_y` reaching from x = base.x + arm_x0 to base.x + arm_x1 (arm_x0 <
// arm_x1; the body lies inside that range).
void AddLatticeTower(Vec3 base, double height, double base_width, double top_width,
                     double crossarm_y, double arm_x0, double arm_x1, std::vector<Shape>* shapes) {
  auto add = [&](Vec3 a, Vec3 b, double radius) {
    shapes->push_back(
        Tagged(MakeCapsule(a, b, radius), Material::kTowerSteel, kClassTower, 0, 7.0));
  };
  constexpr int kPanels = 9;
  auto corner = [&](int level, int k) {
    const double t = static_cast<double>(level) / kPanels;
    const double y = base.y - t * height;
    const double half = 0.5 * (base_width + (top_width - base_width) * std::sqrt(t));
    const double sx = (k == 0 || k == 3) ? -1 : 1, sz = (k < 2) ? -1 : 1;
    return Vec3{base.x + sx * half, y, base.z + sz * half};
  };
  for (int level = 0; level < kPanels; ++level) {
    for (int k = 0; k < 4; ++k) {
      const int next = (k + 1) % 4;
      add(corner(level, k), corner(level + 1, k), 0.12);         // leg
      add(corner(level + 1, k), corner(level + 1, next), 0.05);  // horizontal
      add(corner(level, k), corner(level + 1, next), 0.04);      // diagonals
      add(corner(level, next), corner(level + 1, k), 0.04);
    }
  }
  // Crossarm: a lattice beam across the line.
  const double arm_y = crossarm_y;
  for (double dz : {-0.5, 0.5}) {
    for (double dy : {0.0, -0.6}) {
      add({base.x + arm_x0, arm_y + dy, base.z + dz}, {base.x + arm_x1, arm_y + dy, base.z + dz},
          0.06);
    }
  }
  for (double x = arm_x0; x < arm_x1 - 1e-9; x += 1.0) {
    add({base.x + x, arm_y, base.z - 0.5}, {base.x + x + 1.0, arm_y - 0.6, base.z - 0.5}, 0.035);
    add({base.x + x, arm_y, base.z + 0.5}, {base.x + x + 1.0, arm_y - 0.6, base.z + 0.5}, 0.035);
  }
  // Peak above the crossarm.
  const Vec3 top{base.x, base.y - height - 4.0, base.z};
  for (int k = 0; k < 4; ++k) add(corner(kPanels, k), top, 0.08);
}

struct SceneParts {
  std::vector<Shape> fixed;  // conductors, towers
  std::vector<std::vector<Shape>> obstacles;
};

detail::ShadingEnvironment MakeEnvironment(const PowerLineSceneOptions& o) {
  detail::ShadingEnvironment env;
  env.up = {0, -1, 0};
  const double elevation = o.sun_elevation_deg * std::numbers::pi / 180.0;
  const double azimuth = o.sun_azimuth_deg * std::numbers::pi / 180.0;
  env.to_sun = {std::cos(elevation) * std::sin(azimuth), -std::sin(elevation),
                std::cos(elevation) * std::cos(azimuth)};
  env.ambient = o.ambient;
  env.sky = true;
  env.cloud_cover = o.cloud_cover;
  env.seed = detail::Mix64(o.seed);
  env.conductor_strands = o.conductor_strands;
  env.conductor_lay_length_m = o.conductor_lay_length_m;
  return env;
}

void AssembleScene(const PowerLineSceneOptions& o, const SceneParts& parts, size_t num_obstacles,
                   detail::RenderScene* scene) {
  scene->geometry = detail::RayScene();
  for (const Shape& s : parts.fixed) scene->geometry.Add(s);
  for (size_t i = 0; i < num_obstacles && i < parts.obstacles.size(); ++i) {
    for (const Shape& s : parts.obstacles[i]) scene->geometry.Add(s);
  }
  scene->geometry.SetGroundPlane({0, 1, 0}, o.ground_depth_m, kClassGround);
  scene->geometry.Build();
  scene->environment = MakeEnvironment(o);
}

// Rectangle of the rectified image that can show the shapes (projected bounding boxes).
cv::Rect ProjectedBounds(const std::vector<Shape>& shapes, const detail::PosedCamera& camera,
                         const CameraIntrinsics& k, cv::Size size) {
  double u_min = 1e300, u_max = -1e300, v_min = 1e300, v_max = -1e300;
  for (const Shape& s : shapes) {
    if (s.obstacle_id == 0) continue;  // e.g. the crossarm above an insulator string
    Vec3 lo, hi;
    detail::ShapeBounds(s, &lo, &hi);
    for (int corner = 0; corner < 8; ++corner) {
      const Vec3 p{(corner & 1) ? hi.x : lo.x, (corner & 2) ? hi.y : lo.y,
                   (corner & 4) ? hi.z : lo.z};
      const Vec3 c = camera.camera_from_scene.Apply(p) + camera.translation;
      if (c.z < 0.02) return {0, 0, size.width, size.height};
      const double u = k.fx * c.x / c.z + k.cx, v = k.fy * c.y / c.z + k.cy;
      u_min = std::min(u_min, u);
      u_max = std::max(u_max, u);
      v_min = std::min(v_min, v);
      v_max = std::max(v_max, v);
    }
  }
  const cv::Rect all(0, 0, size.width, size.height);
  if (u_max < -2 || v_max < -2 || u_min > size.width + 2 || v_min > size.height + 2) return {};
  const int x0 = static_cast<int>(std::floor(std::max(-1.0, u_min))) - 1;
  const int y0 = static_cast<int>(std::floor(std::max(-1.0, v_min))) - 1;
  const int x1 = static_cast<int>(std::ceil(std::min(size.width + 1.0, u_max))) + 2;
  const int y1 = static_cast<int>(std::ceil(std::min(size.height + 1.0, v_max))) + 2;
  return cv::Rect(x0, y0, x1 - x0, y1 - y0) & all;
}

double SurfaceMinDepth(const std::vector<Shape>& shapes, const detail::PosedCamera& rectified) {
  // Z_rect = Dot(w, X) for a world point X, since the rectified left camera sits at the origin.
  const Vec3 w = rectified.camera_from_scene.r2;
  double best = std::numeric_limits<double>::infinity();
  for (const Shape& s : shapes) {
    if (s.obstacle_id == 0) continue;
    best = std::min(best, detail::MinAlongDirection(s, w));
  }
  return best;
}

}  // namespace

namespace detail {

VisibleStats MeasureVisible(const cv::Mat& depth, const cv::Mat& ids, int id, cv::Rect roi) {
  VisibleStats stats;
  int x0 = INT32_MAX, y0 = INT32_MAX, x1 = -1, y1 = -1;
  for (int v = roi.y; v < roi.y + roi.height; ++v) {
    const auto* z = depth.ptr<float>(v);
    const auto* label = ids.ptr<unsigned char>(v);
    for (int u = roi.x; u < roi.x + roi.width; ++u) {
      if (label[u] != id) continue;
      ++stats.pixels;
      if (z[u] < stats.min_depth) {
        stats.min_depth = z[u];
        stats.nearest = {u, v};
      }
      x0 = std::min(x0, u);
      y0 = std::min(y0, v);
      x1 = std::max(x1, u);
      y1 = std::max(y1, v);
    }
  }
  if (stats.pixels > 0) stats.box = cv::Rect(x0, y0, x1 - x0 + 1, y1 - y0 + 1);
  return stats;
}

PowerLineSceneModel BuildPowerLineSceneModel(const PowerLineSceneOptions& options) {
  options.Check();
  PowerLineSceneModel model;
  model.calibration = MakeStereoCalibration(options.rig);
  const cv::Size size = options.rig.image_size;
  const LineGeometry line(options);
  model.poses = MakeRigPoses(model.calibration, line.left_from_world());
  const RigPoses& poses = model.poses;
  const CameraIntrinsics rect_k = RectifiedIntrinsics(model.calibration);

  SceneParts parts;
  AddConductors(options, line, &parts.fixed);
  if (options.towers) {
    const double span = options.span_ahead_m;
    const Vec3 end0 = line.Point(0, span);
    const double middle_x =
        end0.x + 0.5 * (options.num_conductors - 1) * options.conductor_spacing_m;
    const double crossarm_y = end0.y - 1.5;
    const double height = options.ground_depth_m - crossarm_y;
    // The end tower's body stands tower_offset_x_m beside the middle of the conductors; its
    // crossarm reaches from the body across all conductors.
    const double body_x = middle_x + options.tower_offset_x_m;
    const double reach = 3.0 + 0.5 * options.num_conductors * options.conductor_spacing_m;
    const double arm_x0 = std::min(-3.0, middle_x - reach - body_x);
    const double arm_x1 = std::max(3.0, middle_x + reach - body_x);
    AddLatticeTower({body_x, options.ground_depth_m, span + 0.6}, height, 7.0, 1.8, crossarm_y,
                    arm_x0, arm_x1, &parts.fixed);
    // The neighbouring line of the corridor, off to the side.
    AddLatticeTower({middle_x + 28.0, options.ground_depth_m, 0.35 * span + 25.0}, height + 4.0,
                    7.0, 1.8, crossarm_y - 4.0, -4.0, 4.0, &parts.fixed);
    AddLatticeTower({middle_x + 28.0, options.ground_depth_m, 1.35 * span + 25.0}, height + 4.0,
                    7.0, 1.8, crossarm_y - 4.0, -4.0, 4.0, &parts.fixed);
    // Its conductors, sagging between the two crossarms (plain cables: far away, no strand detail).
    const double z0 = 0.35 * span + 25.0, z1 = 1.35 * span + 25.0,
                 attach_y = crossarm_y - 4.0 + 1.5;
    for (double dx : {-3.5, 3.5}) {
      const double a = 600.0, middle = 0.5 * (z0 + z1);
      auto point = [&](double z) {
        return Vec3{middle_x + 28.0 + dx,
                    attach_y + a * (std::cosh((z0 - middle) / a) - std::cosh((z - middle) / a)), z};
      };
      constexpr int kSegments = 40;
      for (int k = 0; k < kSegments; ++k) {
        const double za = z0 + (z1 - z0) * k / kSegments, zb = z0 + (z1 - z0) * (k + 1) / kSegments;
        parts.fixed.push_back(Tagged(MakeCapsule(point(za), point(zb), 0.015),
                                     Material::kTowerSteel, kClassConductor, 0, 3.0));
      }
    }
  }

  // Place obstacles nearest first: a farther obstacle can never hide a nearer one's nearest pixel.
  std::vector<size_t> order(options.obstacles.size());
  std::iota(order.begin(), order.end(), 0);
  auto order_key = [&](size_t i) {
    return options.obstacles[i].arc_m.value_or(options.obstacles[i].distance_m);
  };
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return order_key(a) < order_key(b); });
  model.arc.assign(options.obstacles.size(), 0.0);
  // Arcs are counted from the point of conductor 0 nearest to the left camera centre (the world
  // origin): golden-section search of |P(h)| near h = 0.
  double h_lo = -2.0, h_hi = 2.0;
  for (int i = 0; i < 100; ++i) {
    const double a = h_hi - 0.618033988749895 * (h_hi - h_lo);
    const double b = h_lo + 0.618033988749895 * (h_hi - h_lo);
    if (detail::Norm(line.Point(0, a)) < detail::Norm(line.Point(0, b))) {
      h_hi = b;
    } else {
      h_lo = a;
    }
  }
  const double arc_origin = line.Arc(0.5 * (h_lo + h_hi));
  const double radius = options.conductor_radius_m;
  const Vec3 w = poses.rectified_left.camera_from_scene.r2;
  // Defects are part of the line: fixed before the obstacles are placed, so that what they hide is
  // taken into account.
  for (size_t i = 0; i < options.defects.size(); ++i) {
    const DefectSpec& spec = options.defects[i];
    const double arc = arc_origin + spec.arc_m;
    const LocalFrame frame = FrameOnConductor(line, 0, arc);
    std::vector<Shape> shapes;
    detail::AddDefect(spec, static_cast<int>(i), frame, radius, arc, options.conductor_strands,
                      &shapes);
    // Extent along the line: the support of its shapes along the tangent at its centre.
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const Shape& s : shapes) {
      lo = std::min(lo, detail::MinAlongDirection(s, frame.along));
      hi = std::max(hi, -detail::MinAlongDirection(s, -frame.along));
    }
    const double centre = Dot(frame.along, frame.origin);
    model.defect_extent.push_back({spec.arc_m + lo - centre, spec.arc_m + hi - centre});
    parts.fixed.insert(parts.fixed.end(), shapes.begin(), shapes.end());
  }
  std::vector<std::vector<Shape>> placed(options.obstacles.size());
  SceneParts assembly;
  assembly.fixed = parts.fixed;
  detail::RenderScene scene;
  for (size_t rank = 0; rank < order.size(); ++rank) {
    const size_t index = order[rank];
    const ObstacleSpec& spec = options.obstacles[index];
    const int id = static_cast<int>(index) + 1;
    auto build = [&](double arc) {
      std::vector<Shape> shapes;
      AddObstacle(spec.type, Tilted(FrameOnConductor(line, spec.conductor, arc), spec.tilt_deg),
                  radius, id, &shapes);
      return shapes;
    };
    if (spec.arc_m) {  // placed on the line, its distance is whatever it is
      placed[index] = build(arc_origin + *spec.arc_m);
      model.arc[index] = *spec.arc_m;
      continue;
    }
    // Start from the arc where the analytic nearest surface is at the requested depth, then slide
    // until the nearest VISIBLE pixel is (a safeguarded Newton iteration; depth grows with arc).
    const double slope = std::max(0.2, Dot(w, line.Tangent(line.HorizontalAt(spec.distance_m))));
    double arc = spec.distance_m;
    for (int i = 0; i < 30; ++i) {
      const double error = SurfaceMinDepth(build(arc), poses.rectified_left) - spec.distance_m;
      if (std::fabs(error) < 1e-12) break;
      arc -= error / slope;
    }
    auto visible_min = [&](double at_arc, std::vector<Shape>* shapes) {
      *shapes = build(at_arc);
      assembly.obstacles.assign(1, *shapes);
      SceneParts current = assembly;
      for (size_t j = 0; j < rank; ++j)
        current.fixed.insert(current.fixed.end(), placed[order[j]].begin(), placed[order[j]].end());
      AssembleScene(options, current, 1, &scene);
      const cv::Rect roi = ProjectedBounds(*shapes, poses.rectified_left, rect_k, size);
      cv::Mat depth, cls, ids;
      detail::TraceGroundTruth(scene, rect_k, poses.rectified_left, size, roi, &depth, &cls, &ids);
      return MeasureVisible(depth, ids, id, roi).min_depth;
    };
    std::vector<Shape> shapes;
    double lo = -1e300, hi = 1e300;  // bracket on arc: V(lo) < target < V(hi)
    double best_error = std::numeric_limits<double>::infinity();
    double best_arc = arc;
    for (int iteration = 0; iteration < 40; ++iteration) {
      const double value = visible_min(arc, &shapes);
      if (!std::isfinite(value)) {
        throw InputError(fmt::format(
            "obstacle {} ({} at {} m on conductor {}) is not visible in the rectified left image",
            id, ObstacleTypeName(spec.type), spec.distance_m, spec.conductor));
      }
      const double error = value - spec.distance_m;
      if (std::fabs(error) < std::fabs(best_error)) {
        best_error = error;
        best_arc = arc;
      }
      if (std::fabs(error) < 2e-6) break;
      if (error < 0) lo = std::max(lo, arc);
      if (error > 0) hi = std::min(hi, arc);
      double next = arc - error / slope;
      if (lo > -1e299 && hi < 1e299 && (next <= lo || next >= hi)) next = 0.5 * (lo + hi);
      if (hi - lo < 1e-9) break;
      arc = next;
    }
    if (arc != best_arc) visible_min(best_arc, &shapes);
    if (line.HorizontalAt(best_arc) > 0.95 * line.span()) {
      throw InputError(
          fmt::format("obstacle {} ({} at {} m) falls beyond the span to the next tower", id,
                      ObstacleTypeName(spec.type), spec.distance_m));
    }
    placed[index] = shapes;
    model.arc[index] = best_arc - arc_origin;
  }
  for (int k = 0; k <= 410; ++k) {
    const double arc = -0.5 + 0.05 * k;
    const Vec3 p = line.Point(0, line.HorizontalAt(arc_origin + arc));
    const Vec3 x = poses.rectified_left.camera_from_scene.Apply(p - poses.rectified_left.centre);
    model.conductor_axis.push_back({arc, cv::Point3d(x.x, x.y, x.z)});
  }

  // Final scene with every obstacle.
  parts.obstacles = placed;
  AssembleScene(options, parts, placed.size(), &model.scene);
  for (const auto& shapes : placed) {
    model.surface_min_depth.push_back(SurfaceMinDepth(shapes, poses.rectified_left));
  }
  return model;
}

}  // namespace detail

}  // namespace linesight::sim
