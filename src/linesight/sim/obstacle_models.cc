// Geometry of the obstacles on a conductor: Stockbridge damper, suspension clamp and insulator
// string (ObstacleType, power_line_scene.h), built from the analytic shapes of ray_tracing.h in an
// obstacle's local frame.
#include <array>
#include <cstdint>
#include <vector>

#include "linesight/sim/power_line_internal.h"
#include "linesight/sim/ray_tracing.h"

namespace linesight::sim::detail {

namespace {

// Suspension clamp body around the conductor (used alone and at the bottom of insulator strings).
void AddSuspensionClamp(const LocalFrame& f, double r, int id, std::vector<Shape>* shapes) {
  const Mat3 axes = f.Axes();
  auto add = [&](Shape s, Material m) { shapes->push_back(Tagged(s, m, kClassObstacle, id, id)); };
  // Body: a cast box cradling the conductor, its flat front face looking along the line.
  add(MakeBox(f.At(0, 0.35 * r + 0.006, 0), axes, {0.095, 0.75 * r + 0.018, r + 0.012}),
      Material::kCastAluminium);
  // Keeper on top, held by two U-bolts.
  add(MakeBox(f.At(0, -r - 0.006, 0), axes, {0.05, 0.007, r + 0.010}), Material::kCastAluminium);
  for (double a : {-0.035, 0.035}) {
    add(MakeFrustum(f.At(a, -r - 0.013, -(r + 0.016)), 0.0055, f.At(a, -r - 0.013, r + 0.016),
                    0.0055),
        Material::kGalvanised);
    for (double side : {-1.0, 1.0}) {
      add(MakeFrustum(f.At(a, -r - 0.02, side * (r + 0.010)), 0.007,
                      f.At(a, -r + 0.003, side * (r + 0.010)), 0.007),
          Material::kGalvanised);
    }
  }
  // Side plates rising to the hanger pin.
  for (double side : {-1.0, 1.0}) {
    add(MakeBox(f.At(0, -r - 0.045, side * (r + 0.006)), axes, {0.018, 0.035, 0.003}),
        Material::kGalvanised);
  }
  add(MakeFrustum(f.At(0, -r - 0.07, -(r + 0.02)), 0.008, f.At(0, -r - 0.07, r + 0.02), 0.008),
      Material::kGalvanised);
}

void AddDamper(const LocalFrame& f, double r, int id, std::vector<Shape>* shapes) {
  const Mat3 axes = f.Axes();
  auto add = [&](Shape s, Material m) { shapes->push_back(Tagged(s, m, kClassObstacle, id, id)); };
  // Clamp gripping the conductor and the drop to the messenger.
  add(MakeBox(f.At(0, 0.002, 0), axes, {0.028, r + 0.010, r + 0.008}), Material::kCastAluminium);
  add(MakeBox(f.At(0, r + 0.032, 0), axes, {0.014, 0.028, 0.009}), Material::kCastAluminium);
  add(MakeFrustum(f.At(0, r + 0.004, -(r + 0.014)), 0.006, f.At(0, r + 0.004, r + 0.014), 0.006),
      Material::kGalvanised);
  // Messenger cable parallel to the conductor.
  const double messenger_depth = r + 0.062;
  Shape messenger = Cable(
      MakeCapsule(f.At(-0.15, messenger_depth, 0), f.At(0.15, messenger_depth, 0), 0.0065), 0.0);
  add(messenger, Material::kMessenger);
  // Two dumbbell weights: neck, body and a flat end cap facing along the line. The front weight is
  // a little larger (asymmetric dampers cover two frequency bands).
  for (double sign : {1.0, -1.0}) {
    const double body_radius = sign > 0 ? 0.030 : 0.026;
    const double body_length = sign > 0 ? 0.100 : 0.085;
    const double depth = messenger_depth + 0.010;
    const double neck_start = 0.095, body_start = 0.125;
    add(MakeFrustum(f.At(sign * neck_start, depth - 0.006, 0), 0.011,
                    f.At(sign * body_start, depth, 0), body_radius * 0.8),
        Material::kDamperWeight);
    add(MakeFrustum(f.At(sign * body_start, depth, 0), body_radius * 0.8,
                    f.At(sign * (body_start + 0.02), depth, 0), body_radius),
        Material::kDamperWeight);
    add(MakeFrustum(f.At(sign * (body_start + 0.02), depth, 0), body_radius,
                    f.At(sign * (body_start + body_length), depth, 0), body_radius),
        Material::kDamperWeight);
  }
}

// Insulator string hanging from a crossarm above the conductor, with its suspension clamp.
void AddInsulatorString(const LocalFrame& f, double r, int id, std::vector<Shape>* shapes) {
  AddSuspensionClamp(f, r, id, shapes);
  auto add = [&](Shape s, Material m, std::uint8_t cls, int obstacle) {
    shapes->push_back(Tagged(s, m, cls, obstacle, id));
  };
  const Vec3 up{0, -1, 0};
  const Vec3 hanger = f.At(0, -r - 0.07, 0);
  auto above = [&](double height) { return hanger + height * up; };
  // Ball-and-socket link from the clamp to the first disc.
  add(MakeFrustum(above(0.0), 0.009, above(0.09), 0.009), Material::kGalvanised, kClassObstacle,
      id);
  // Standard 255 mm glass discs, 146 mm pitch.
  constexpr int kDiscs = 7;
  constexpr double kPitch = 0.146, kDiscRadius = 0.1275;
  double bottom = 0.09;
  for (int i = 0; i < kDiscs; ++i) {
    // Rim band (its front is the nearest surface of the string), shed cone, cap and pin.
    add(MakeFrustum(above(bottom), kDiscRadius, above(bottom + 0.012), kDiscRadius),
        Material::kGlass, kClassObstacle, id);
    add(MakeFrustum(above(bottom + 0.012), kDiscRadius - 0.004, above(bottom + 0.06), 0.045),
        Material::kGlass, kClassObstacle, id);
    add(MakeFrustum(above(bottom + 0.06), 0.040, above(bottom + 0.10), 0.030),
        Material::kGalvanised, kClassObstacle, id);
    add(MakeFrustum(above(bottom + 0.10), 0.009, above(bottom + kPitch), 0.009),
        Material::kGalvanised, kClassObstacle, id);
    bottom += kPitch;
  }
  // Yoke plate, then the crossarm beam of the tower (not part of the obstacle).
  add(MakeBox(above(bottom + 0.04), Mat3::FromColumns({1, 0, 0}, {0, 1, 0}, {0, 0, 1}),
              {0.05, 0.04, 0.008}),
      Material::kGalvanised, kClassObstacle, id);
  const Vec3 beam_centre = above(bottom + 0.08 + 0.12);
  for (double dz : {-0.25, 0.25}) {
    for (double dy : {-0.1, 0.1}) {
      add(MakeCapsule(beam_centre + Vec3{-1.5, dy, dz}, beam_centre + Vec3{1.5, dy, dz}, 0.035),
          Material::kTowerSteel, kClassTower, 0);
    }
  }
  for (double x = -1.5; x < 1.49; x += 0.5) {
    add(MakeCapsule(beam_centre + Vec3{x, 0.1, -0.25}, beam_centre + Vec3{x + 0.5, -0.1, 0.25},
                    0.02),
        Material::kTowerSteel, kClassTower, 0);
  }
}

}  // namespace

void AddObstacle(ObstacleType type, const LocalFrame& f, double r, int id,
                 std::vector<Shape>* shapes) {
  switch (type) {
    case ObstacleType::kDamper:
      AddDamper(f, r, id, shapes);
      break;
    case ObstacleType::kSuspensionClamp:
      AddSuspensionClamp(f, r, id, shapes);
      break;
    case ObstacleType::kInsulatorString:
      AddInsulatorString(f, r, id, shapes);
      break;
  }
}

}  // namespace linesight::sim::detail

namespace linesight::sim {

std::array<double, 2> ObstacleAlongExtent(ObstacleType type) {
  switch (type) {
    case ObstacleType::kDamper:  // the weights' end caps, 0.125 + 0.085 m behind, + 0.100 m ahead
      return {-0.210, 0.225};
    case ObstacleType::kSuspensionClamp:  // the cast body, 0.190 m long
      return {-0.095, 0.095};
    case ObstacleType::kInsulatorString:  // the disc rims, 255 mm across
      return {-0.1275, 0.1275};
  }
  return {0.0, 0.0};
}

}  // namespace linesight::sim
