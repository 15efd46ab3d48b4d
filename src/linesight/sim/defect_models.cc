// Geometry of the conductor defects (DefectType, power_line_scene.h): a birdcage bulge, broken
// outer strands, a hanging string, a plastic sheet and a bird's nest, built from the analytic
// shapes of ray_tracing.h in the local frame of conductor 0 at the defect's arc.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <numbers>
#include <vector>

#include "linesight/sim/power_line_internal.h"
#include "linesight/sim/procedural_texture.h"
#include "linesight/sim/ray_tracing.h"

namespace linesight::sim::detail {

namespace {

constexpr double kDegree = std::numbers::pi / 180.0;
// One wire of an ACSR outer layer is about 3.5 mm across.
constexpr double kStrandRadius = 0.00175;
constexpr double kRopeRadius = 0.0025;

// Direction around the line at `angle` (rad): 0 = down, pi/2 = side, pi = up.
Vec3 AroundLine(const LocalFrame& f, double angle) {
  return std::cos(angle) * f.down + std::sin(angle) * f.side;
}

// Seed of the random details of a defect (twigs, sway), from its spec only: the defect looks the
// same whatever the scene seed and wherever the robot is.
std::uint64_t DetailSeed(const DefectSpec& spec, int index) {
  std::uint64_t bits[3];
  std::memcpy(&bits[0], &spec.arc_m, sizeof(double));
  std::memcpy(&bits[1], &spec.length_m, sizeof(double));
  std::memcpy(&bits[2], &spec.angle_deg, sizeof(double));
  return Mix64(Mix64(Mix64(bits[0] ^ 0xd3f3c7ULL) ^ bits[1]) ^ bits[2]) + index;
}

// Tags the shapes of one defect: material, surface class, texture seed and defect id.
class DefectBuilder {
 public:
  DefectBuilder(int id, std::uint8_t surface_class, double texture_seed, std::vector<Shape>* shapes)
      : id_(id), class_(surface_class), texture_seed_(texture_seed), shapes_(shapes) {}

  Shape& Add(Shape s, Material material) {
    Shape tagged = Tagged(s, material, class_, 0, texture_seed_);
    tagged.defect_id = static_cast<std::uint8_t>(id_);
    shapes_->push_back(tagged);
    return shapes_->back();
  }

 private:
  int id_;
  std::uint8_t class_;
  double texture_seed_;
  std::vector<Shape>* shapes_;
};

// The outer strands spread into a bulge: an ellipsoid around the axis, length_m long and
// r * (1 + swelling) across, whose texture continues the conductor's helix with gaps between the
// loosened strands.
void AddBirdcage(const DefectSpec& spec, const LocalFrame& f, double r, double arc_at_origin,
                 int id, std::vector<Shape>* shapes) {
  DefectBuilder add(id, kClassConductor, 0.0, shapes);
  const double radius = r * (1.0 + spec.swelling);
  Shape bulge = MakeEllipsoid(f.origin, f.Axes(), {0.5 * spec.length_m, radius, radius});
  const Vec3 x{1, 0, 0};
  bulge.reference = Normalized(x - Dot(x, f.along) * f.along);  // as Cable() for the conductor
  bulge.arc_offset = arc_at_origin;
  bulge.r0 = r;  // the shader's strands keep the conductor's wire width
  add.Add(bulge, Material::kBirdcage);
}

// Cut outer strands: each leaves the surface at the defect's arc, in a radial half-plane at
// angle_deg around the line (neighbouring strands one wire apart), and bends away in two straight
// pieces so that its free end stands standoff_m off the surface.
void AddBrokenStrands(const DefectSpec& spec, const LocalFrame& f, double r, int lay_strands,
                      int id, std::vector<Shape>* shapes) {
  DefectBuilder add(id, kClassConductor, 0.0, shapes);
  const double run = std::clamp(0.03 + spec.standoff_m, 0.03, 0.10);
  const double spacing = 2.0 * std::numbers::pi / lay_strands;
  for (int k = 0; k < spec.strands; ++k) {
    const double angle = spec.angle_deg * kDegree + (k - 0.5 * (spec.strands - 1)) * spacing;
    const Vec3 out = AroundLine(f, angle);
    const double length = run * (1.0 - 0.12 * k);
    const double standoff = spec.standoff_m * (1.0 - 0.2 * k);
    const double start = -0.5 * run + 0.008 * k;
    auto at = [&](double a, double radial) { return f.origin + a * f.along + radial * out; };
    const Vec3 root = at(start, r - 0.3 * kStrandRadius);  // sunk into the conductor
    const Vec3 bend = at(start + 0.4 * length, r + 0.25 * standoff);
    const Vec3 end = at(start + length, r + standoff);
    add.Add(MakeCapsule(root, bend, kStrandRadius), Material::kLooseStrand);
    add.Add(MakeCapsule(bend, end, kStrandRadius), Material::kLooseStrand);
  }
}

// A rope wrapped twice around the conductor, hanging length_m from it in the direction angle_deg
// around the line with a slight sway, its end frayed.
void AddHangingString(const DefectSpec& spec, const LocalFrame& f, double r, int id, int index,
                      std::vector<Shape>* shapes) {
  DefectBuilder add(id, kClassObstacle, 100.0 + index, shapes);
  NoiseStream random(DetailSeed(spec, index));
  const double wrap_radius = r + 0.7 * kRopeRadius;
  double texture_arc = 0.0;
  auto rope = [&](Vec3 a, Vec3 b, double radius) {
    add.Add(Cable(MakeCapsule(a, b, radius), texture_arc), Material::kRope);
    texture_arc += Norm(b - a);
  };
  constexpr int kWrapSegments = 10;
  const double hang = spec.angle_deg * kDegree;
  for (double a : {-0.0045, 0.0045}) {
    for (int j = 0; j < kWrapSegments; ++j) {
      const double phi0 = hang + 2.0 * std::numbers::pi * j / kWrapSegments;
      const double phi1 = hang + 2.0 * std::numbers::pi * (j + 1) / kWrapSegments;
      rope(f.origin + a * f.along + wrap_radius * AroundLine(f, phi0),
           f.origin + a * f.along + wrap_radius * AroundLine(f, phi1), kRopeRadius);
    }
  }
  const Vec3 down = AroundLine(f, hang);
  const Vec3 across = AroundLine(f, hang + 0.5 * std::numbers::pi);
  const double sway_along =
      (random.Uniform() < 0.5 ? -1.0 : 1.0) * (0.05 + 0.05 * random.Uniform());
  const double sway_across = 0.03 + 0.04 * random.Uniform();
  const double phase = 2.0 * std::numbers::pi * random.Uniform();
  const Vec3 top = f.origin + wrap_radius * down;
  const double length = spec.length_m;
  auto point = [&](double t) {
    return top + (t * length) * down +
           (length * sway_along * std::sin(0.9 * std::numbers::pi * t)) * f.along +
           (length * sway_across * std::sin(1.4 * std::numbers::pi * t + phase) -
            length * sway_across * std::sin(phase)) *
               across;
  };
  const int segments = std::clamp(static_cast<int>(std::ceil(length / 0.03)), 4, 50);
  Vec3 previous = point(0.0);
  for (int k = 1; k <= segments; ++k) {
    const Vec3 next = point(static_cast<double>(k) / segments);
    rope(previous, next, kRopeRadius);
    previous = next;
  }
  // Frayed end: a few loose fibres spreading from the last knot.
  const Vec3 tail = Normalized(point(1.0) - point(1.0 - 1.0 / segments));
  const double fibre = std::min(0.015, 0.3 * length);
  for (int k = 0; k < 3; ++k) {
    const double spread = 2.0 * std::numbers::pi * (k + random.Uniform() * 0.5) / 3.0;
    const Vec3 sideways = std::cos(spread) * f.along + std::sin(spread) * across;
    rope(previous, previous + fibre * Normalized(tail + 0.45 * sideways), 0.4 * kRopeRadius);
  }
}

// A plastic sheet wrapped over the conductor (a thin sleeve) and hanging from it in the direction
// angle_deg around the line, billowing to one side in three strips; length_m wide along the line
// and 0.85 length_m deep.
void AddPlasticSheet(const DefectSpec& spec, const LocalFrame& f, double r, int id, int index,
                     std::vector<Shape>* shapes) {
  DefectBuilder add(id, kClassObstacle, 100.0 + index, shapes);
  NoiseStream random(DetailSeed(spec, index));
  const double width = spec.length_m, depth = 0.85 * spec.length_m;
  const double sleeve = r + 0.0015;
  add.Add(MakeFrustum(f.origin - 0.5 * width * f.along, sleeve, f.origin + 0.5 * width * f.along,
                      sleeve),
          Material::kPlasticSheet);
  const double hang = spec.angle_deg * kDegree;
  const Vec3 down = AroundLine(f, hang);
  const Vec3 across = AroundLine(f, hang + 0.5 * std::numbers::pi);
  const double side = random.Uniform() < 0.5 ? -1.0 : 1.0;
  Vec3 top = f.origin + sleeve * down;
  constexpr int kStrips = 3;
  for (int k = 0; k < kStrips; ++k) {
    // Each strip hangs a little further out: the sheet bellies in the wind.
    const double tilt = side * (0.12 + 0.14 * k + 0.1 * random.Uniform());
    const Vec3 v = std::cos(tilt) * down + std::sin(tilt) * across;
    const Vec3 bottom = top + (depth / kStrips) * v;
    add.Add(MakeRectangle(0.5 * (top + bottom), f.along, v, 0.5 * width, 0.5 * depth / kStrips),
            Material::kPlasticSheet);
    top = bottom;
  }
}

// A bird's nest on top of the conductor: a rough ellipsoid (length_m across, 0.6 length_m high)
// whose bottom wraps the conductor, with twigs sticking out and straw hanging below.
void AddBirdNest(const DefectSpec& spec, const LocalFrame& f, double r, int id, int index,
                 std::vector<Shape>* shapes) {
  DefectBuilder add(id, kClassObstacle, 100.0 + index, shapes);
  NoiseStream random(DetailSeed(spec, index));
  const double diameter = spec.length_m, height = 0.6 * spec.length_m;
  const Vec3 up = -1.0 * f.down;
  const Vec3 centre = f.origin + (0.5 * height - 1.5 * r) * up;
  const Vec3 semi{0.5 * diameter, 0.5 * height, 0.45 * diameter};
  add.Add(MakeEllipsoid(centre, f.Axes(), semi), Material::kNest);
  auto on_surface = [&](double azimuth, double elevation, double scale) {
    return centre + (scale * semi.x * std::cos(elevation) * std::cos(azimuth)) * f.along -
           (scale * semi.y * std::sin(elevation)) * f.down +
           (scale * semi.z * std::cos(elevation) * std::sin(azimuth)) * f.side;
  };
  // Lumps of the rim.
  for (int k = 0; k < 6; ++k) {
    const double azimuth = 2.0 * std::numbers::pi * (k + 0.6 * random.Uniform()) / 6.0;
    const Vec3 lump = on_surface(azimuth, 0.35 + 0.3 * random.Uniform(), 0.8);
    const double size = (0.16 + 0.08 * random.Uniform()) * diameter;
    add.Add(MakeEllipsoid(lump, f.Axes(), {size, 0.6 * size, 0.9 * size}), Material::kNest);
  }
  // Twigs: mostly tangent to the surface, poking out at one end.
  for (int k = 0; k < 28; ++k) {
    const double azimuth = 2.0 * std::numbers::pi * random.Uniform();
    const double elevation = std::asin(2.0 * random.Uniform() - 1.0);
    const Vec3 anchor = on_surface(azimuth, elevation, 0.92);
    const Vec3 outward = Normalized(anchor - centre);
    Vec3 tangent{random.Gaussian(), random.Gaussian(), random.Gaussian()};
    tangent = tangent - Dot(tangent, outward) * outward;
    if (Norm(tangent) < 1e-6) tangent = f.along;
    const Vec3 direction = Normalized(Normalized(tangent) + 0.35 * outward);
    const double length = (0.25 + 0.25 * random.Uniform()) * diameter;
    add.Add(MakeCapsule(anchor - 0.45 * length * direction, anchor + 0.55 * length * direction,
                        0.0018 + 0.0017 * random.Uniform()),
            Material::kNest);
  }
  // Straw and grass hanging below the conductor.
  for (int k = 0; k < 5; ++k) {
    const double a = (random.Uniform() - 0.5) * 0.7 * diameter;
    const double lateral = (random.Uniform() - 0.5) * 0.5 * diameter;
    const Vec3 root = f.origin + a * f.along + (1.2 * r) * f.down + lateral * f.side;
    const double length = (0.2 + 0.3 * random.Uniform()) * diameter;
    const Vec3 drift = (random.Uniform() - 0.5) * 0.5 * f.along + (random.Uniform() - 0.5) * f.side;
    add.Add(MakeCapsule(root + (-0.2 * length) * f.down,
                        root + length * Normalized(f.down + 0.4 * drift), 0.0012),
            Material::kNest);
  }
}

}  // namespace

void AddDefect(const DefectSpec& spec, int index, const LocalFrame& f, double r,
               double arc_at_origin, int lay_strands, std::vector<Shape>* shapes) {
  const int id = index + 1;
  switch (spec.type) {
    case DefectType::kBirdcage:
      AddBirdcage(spec, f, r, arc_at_origin, id, shapes);
      break;
    case DefectType::kBrokenStrands:
      AddBrokenStrands(spec, f, r, lay_strands, id, shapes);
      break;
    case DefectType::kHangingString:
      AddHangingString(spec, f, r, id, index, shapes);
      break;
    case DefectType::kPlasticSheet:
      AddPlasticSheet(spec, f, r, id, index, shapes);
      break;
    case DefectType::kBirdNest:
      AddBirdNest(spec, f, r, id, index, shapes);
      break;
  }
}

double DefectSize(const DefectSpec& spec, double r) {
  switch (spec.type) {
    case DefectType::kBirdcage:
      return spec.swelling * r;
    case DefectType::kBrokenStrands:
      return spec.standoff_m;
    case DefectType::kHangingString:
    case DefectType::kPlasticSheet:
    case DefectType::kBirdNest:
      return spec.length_m;
  }
  return 0.0;
}

}  // namespace linesight::sim::detail
