// Internal to the sim module: analytic ray casting over convex primitives with a bounding volume
// hierarchy. Everything is in double precision so that ground truth is exact to rounding.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

namespace linesight::sim::detail {

struct Vec3 {
  double x = 0, y = 0, z = 0;
};
inline Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec3 operator-(Vec3 a) { return {-a.x, -a.y, -a.z}; }
inline Vec3 operator*(double s, Vec3 a) { return {s * a.x, s * a.y, s * a.z}; }
inline Vec3 operator*(Vec3 a, double s) { return {s * a.x, s * a.y, s * a.z}; }
inline double Dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3 Cross(Vec3 a, Vec3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline double Norm(Vec3 a) { return std::sqrt(Dot(a, a)); }
inline Vec3 Normalized(Vec3 a) { return (1.0 / Norm(a)) * a; }
inline Vec3 Min(Vec3 a, Vec3 b) {
  return {std::fmin(a.x, b.x), std::fmin(a.y, b.y), std::fmin(a.z, b.z)};
}
inline Vec3 Max(Vec3 a, Vec3 b) {
  return {std::fmax(a.x, b.x), std::fmax(a.y, b.y), std::fmax(a.z, b.z)};
}

// Rotation matrix stored by rows; Apply(v) = M v.
struct Mat3 {
  Vec3 r0{1, 0, 0}, r1{0, 1, 0}, r2{0, 0, 1};
  Vec3 Apply(Vec3 v) const { return {Dot(r0, v), Dot(r1, v), Dot(r2, v)}; }
  Vec3 ApplyTransposed(Vec3 v) const { return r0 * v.x + r1 * v.y + r2 * v.z; }
  // Columns as given: M = [c0 c1 c2].
  static Mat3 FromColumns(Vec3 c0, Vec3 c1, Vec3 c2) {
    return {{c0.x, c1.x, c2.x}, {c0.y, c1.y, c2.y}, {c0.z, c1.z, c2.z}};
  }
};

struct Ray {
  Vec3 origin;
  Vec3 direction;  // unit length
};

enum class ShapeKind : std::uint8_t {
  kSphere,     // centre p0, radius r0
  kCapsule,    // segment p0-p1, radius r0 (cylinder with hemispherical ends)
  kFrustum,    // capped truncated cone: disc (p0, r0) to disc (p1, r1); r0 == r1 is a cylinder
  kBox,        // centre p0, rotation `frame` (columns = box axes), half extents `half`
  kEllipsoid,  // centre p0, rotation `frame` (columns = axes), semi-axes `half`
  kRectangle,  // planar rectangle: centre p0, frame columns (u axis, v axis, normal), half (hu, hv,
               // -)
};

// What a surface looks like; interpreted by the scene's shader.
enum class Material : std::uint8_t {
  kConductor,      // helically stranded aluminium (uses arc_offset and reference)
  kMessenger,      // stranded steel messenger cable of the damper
  kCastAluminium,  // clamp bodies
  kGalvanised,     // galvanised steel hardware
  kDamperWeight,   // zinc-coated cast weights
  kGlass,          // toughened-glass insulator sheds
  kTowerSteel,     // lattice members
  kChessboard,     // calibration target (rectangle coordinates give the pattern)
  kWall,           // backdrop behind calibration boards
  kBirdcage,       // outer strands of a conductor spread into a bulge (ellipsoid frame, arc_offset,
                   // reference): loose strands with dark gaps onto the inner layer
  kLooseStrand,    // one aluminium wire of a broken outer strand
  kRope,           // twisted synthetic rope (a cable: arc_offset and reference)
  kPlasticSheet,   // thin, creased plastic film
  kNest,           // twigs and straw of a bird's nest
};

struct Shape {
  ShapeKind kind = ShapeKind::kSphere;
  Material material = Material::kGalvanised;
  std::uint8_t surface_class = 0;  // SurfaceClass
  std::uint8_t obstacle_id = 0;    // 0 = not part of an obstacle
  std::uint8_t defect_id = 0;      // 0 = not part of a conductor defect
  Vec3 p0, p1;
  double r0 = 0, r1 = 0;
  Mat3 frame;  // rows of the transposed frame: Apply() maps world -> local
  Vec3 half;
  // Texture parameters: arc length of p0 along a stranded cable and a reference direction
  // perpendicular to the cable axis (for the strand angle); texture seed offset.
  double arc_offset = 0;
  Vec3 reference{1, 0, 0};
  double texture_seed = 0;
};

Shape MakeSphere(Vec3 centre, double radius);
Shape MakeCapsule(Vec3 a, Vec3 b, double radius);
Shape MakeFrustum(Vec3 a, double radius_a, Vec3 b, double radius_b);
// `axes` columns are the box axes in world coordinates (orthonormal); half extents along them.
Shape MakeBox(Vec3 centre, const Mat3& axes_as_columns, Vec3 half_extents);
Shape MakeEllipsoid(Vec3 centre, const Mat3& axes_as_columns, Vec3 semi_axes);
Shape MakeRectangle(Vec3 centre, Vec3 u_axis, Vec3 v_axis, double half_u, double half_v);

struct Hit {
  double t = std::numeric_limits<double>::infinity();  // ray parameter (distance along the ray)
  Vec3 normal;                                         // unit, facing the ray origin
  int shape = -1;                                      // index into the scene's shapes
};

// Closest intersection with t in (t_min, hit->t); updates *hit and returns true if found.
bool IntersectShape(const Shape& shape, const Ray& ray, double t_min, Hit* hit);
// min over the shape's surface of Dot(w, x) (support function of -w, negated): exact for every
// kind.
double MinAlongDirection(const Shape& shape, Vec3 w);
void ShapeBounds(const Shape& shape, Vec3* lo, Vec3* hi);

// A set of shapes with a bounding volume hierarchy and an optional infinite horizontal-ish plane.
class RayScene {
 public:
  int Add(const Shape& shape);  // returns the shape index
  // Infinite plane Dot(normal, x) = offset (normal unit); only one.
  void SetGroundPlane(Vec3 normal, double offset, std::uint8_t surface_class);
  void Build();  // call after the last Add and before Intersect

  // Closest hit with t > t_min; hit.shape == kGroundShape for the plane, -1 for nothing.
  Hit Intersect(const Ray& ray, double t_min = 1e-9) const;
  bool HasGround() const { return has_ground_; }
  std::uint8_t GroundClass() const { return ground_class_; }

  const Shape& shape(int i) const { return shapes_[i]; }
  int size() const { return static_cast<int>(shapes_.size()); }

  static constexpr int kGroundShape = -2;

 private:
  struct Node {
    Vec3 lo, hi;
    int left = -1, right = -1;  // children (internal) or -1
    int first = 0, count = 0;   // leaf range in order_
  };
  int BuildNode(int first, int count);

  std::vector<Shape> shapes_;
  std::vector<Vec3> lo_, hi_;
  std::vector<int> order_;
  std::vector<Node> nodes_;
  bool built_ = false;
  bool has_ground_ = false;
  Vec3 ground_normal_;
  double ground_offset_ = 0;
  std::uint8_t ground_class_ = 0;
};

}  // namespace linesight::sim::detail
