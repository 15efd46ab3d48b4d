// Internal to the sim module: the pieces of the power-line scene shared by its obstacle and defect
// models (obstacle_models.cc, defect_models.cc), its layout (power_line_layout.cc) and its renderer
// (power_line_scene.cc).
#pragma once

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "linesight/sim/power_line_scene.h"
#include "linesight/sim/ray_tracing.h"

namespace linesight::sim::detail {

inline constexpr std::uint8_t kClassGround = static_cast<std::uint8_t>(SurfaceClass::kGround);
inline constexpr std::uint8_t kClassTower = static_cast<std::uint8_t>(SurfaceClass::kTower);
inline constexpr std::uint8_t kClassConductor = static_cast<std::uint8_t>(SurfaceClass::kConductor);
inline constexpr std::uint8_t kClassObstacle = static_cast<std::uint8_t>(SurfaceClass::kObstacle);

// Local frame of an obstacle at arc position `arc` on conductor c: along the line, down
// (perpendicular to it, in the vertical plane) and lateral.
struct LocalFrame {
  Vec3 origin, along, down, side;
  Vec3 At(double a, double d, double l) const { return origin + a * along + d * down + l * side; }
  Mat3 Axes() const { return Mat3::FromColumns(along, down, side); }
};

// `s` with its material, ground-truth labels and texture seed.
inline Shape Tagged(Shape s, Material material, std::uint8_t surface_class, int obstacle_id,
                    double texture_seed) {
  s.material = material;
  s.surface_class = surface_class;
  s.obstacle_id = static_cast<std::uint8_t>(obstacle_id);
  s.texture_seed = texture_seed;
  return s;
}

// A cable texture needs the arc offset at p0 and a reference direction perpendicular to its axis.
inline Shape Cable(Shape s, double arc_offset) {
  const Vec3 axis = Normalized(s.p1 - s.p0);
  const Vec3 x{1, 0, 0};
  s.reference = Normalized(x - Dot(x, axis) * axis);
  s.arc_offset = arc_offset;
  return s;
}

// Appends the shapes of an obstacle of `type` placed in frame `f` on a conductor of radius r (m);
// its shapes carry obstacle id `id` (a crossarm above an insulator string is tower, id 0).
void AddObstacle(ObstacleType type, const LocalFrame& f, double r, int id,
                 std::vector<Shape>* shapes);

// Appends the shapes of defect spec number `index` (0-based; its shapes carry defect id index + 1)
// placed in frame `f` on conductor 0 of radius r (m). `arc_at_origin` is the conductor's texture
// arc at f.origin (so a birdcage continues the helix of the strands) and `lay_strands` the number
// of outer strands.
void AddDefect(const DefectSpec& spec, int index, const LocalFrame& f, double r,
               double arc_at_origin, int lay_strands, std::vector<Shape>* shapes);
// RenderedDefect::size_m of `spec` on a conductor of radius r (m).
double DefectSize(const DefectSpec& spec, double r);
// Throws OptionError naming `name`.<field> when a field of `spec` is out of its range (all but
// arc_m, whose range depends on the span).
void CheckDefectSpec(const DefectSpec& spec, const std::string& name);

// What the rectified left camera sees of obstacle `id` inside `roi` of a ground-truth trace (depth
// Z_rect and obstacle ids).
struct VisibleStats {
  double min_depth = std::numeric_limits<double>::infinity();
  cv::Point nearest{-1, -1};
  cv::Rect box;
  int pixels = 0;
};
VisibleStats MeasureVisible(const cv::Mat& depth, const cv::Mat& ids, int id, cv::Rect roi);

}  // namespace linesight::sim::detail
