#include "linesight/sim/ray_tracing.h"

#include <algorithm>
#include <array>
#include <utility>

#include "linesight/core/error.h"

namespace linesight::sim::detail {
namespace {

Mat3 Transposed(const Mat3& m) {
  return {{m.r0.x, m.r1.x, m.r2.x}, {m.r0.y, m.r1.y, m.r2.y}, {m.r0.z, m.r1.z, m.r2.z}};
}

// Accepts a candidate hit if it is in range and closer than the current one.
bool Accept(double t, double t_min, Hit* hit, Vec3 normal, const Ray& ray) {
  if (!(t > t_min) || !(t < hit->t)) return false;
  hit->t = t;
  hit->normal = Dot(normal, ray.direction) > 0 ? -normal : normal;
  return true;
}

// Both roots of a t^2 + 2 b t + c = 0 in increasing order; false when there is no real root.
bool SolveQuadratic(double a, double b, double c, double* t0, double* t1) {
  if (std::fabs(a) < 1e-300) {
    if (std::fabs(b) < 1e-300) return false;
    *t0 = *t1 = -c / (2.0 * b);
    return true;
  }
  const double disc = b * b - a * c;
  if (disc < 0) return false;
  // Numerically stable form (no cancellation between -b and sqrt(disc)).
  const double q = -(b + std::copysign(std::sqrt(disc), b));
  double r0 = q / a;
  double r1 = q != 0 ? c / q : r0;
  if (r0 > r1) std::swap(r0, r1);
  *t0 = r0;
  *t1 = r1;
  return true;
}

bool IntersectDisc(Vec3 centre, Vec3 normal, double radius, const Ray& ray, double t_min,
                   Hit* hit) {
  if (radius <= 0) return false;
  const double denom = Dot(normal, ray.direction);
  if (std::fabs(denom) < 1e-300) return false;
  const double t = Dot(centre - ray.origin, normal) / denom;
  if (!(t > t_min) || !(t < hit->t)) return false;
  const Vec3 p = ray.origin + t * ray.direction - centre;
  if (Dot(p, p) > radius * radius) return false;
  return Accept(t, t_min, hit, normal, ray);
}

bool IntersectSphere(Vec3 centre, double radius, const Ray& ray, double t_min, Hit* hit) {
  const Vec3 oc = ray.origin - centre;
  const double b = Dot(oc, ray.direction);
  const Vec3 perpendicular = oc - b * ray.direction;
  const double disc = radius * radius - Dot(perpendicular, perpendicular);
  if (disc < 0) return false;
  const double s = std::sqrt(disc);
  bool found = false;
  for (double t : {-b - s, -b + s}) {
    if (t > t_min && t < hit->t) {
      const Vec3 n = (1.0 / radius) * (ray.origin + t * ray.direction - centre);
      found = Accept(t, t_min, hit, n, ray);
      break;
    }
  }
  return found;
}

// Side of a (possibly conical) surface of revolution around the segment p0 + y u, y in [0, length],
// radius r0 + k y.
bool IntersectConeSide(Vec3 p0, Vec3 u, double length, double r0, double k, const Ray& ray,
                       double t_min, Hit* hit) {
  const Vec3 q = ray.origin - p0;
  const double qu = Dot(q, u);
  const double du = Dot(ray.direction, u);
  const Vec3 q_perp = q - qu * u;
  const Vec3 d_perp = ray.direction - du * u;
  const double rq = r0 + k * qu;
  const double a = Dot(d_perp, d_perp) - k * k * du * du;
  const double b = Dot(q_perp, d_perp) - k * rq * du;
  const double c = Dot(q_perp, q_perp) - rq * rq;
  double t0, t1;
  if (!SolveQuadratic(a, b, c, &t0, &t1)) return false;
  for (double t : {t0, t1}) {
    if (!(t > t_min) || !(t < hit->t)) continue;
    const double y = qu + t * du;
    if (y < 0 || y > length) continue;
    if (r0 + k * y < 0) continue;  // the other nappe of the cone
    const Vec3 radial = q_perp + t * d_perp;
    const double radial_norm = Norm(radial);
    if (radial_norm <= 0) continue;
    const Vec3 n = Normalized((1.0 / radial_norm) * radial - k * u);
    return Accept(t, t_min, hit, n, ray);
  }
  return false;
}

}  // namespace

Shape MakeSphere(Vec3 centre, double radius) {
  Shape s;
  s.kind = ShapeKind::kSphere;
  s.p0 = centre;
  s.r0 = radius;
  return s;
}

Shape MakeCapsule(Vec3 a, Vec3 b, double radius) {
  Shape s;
  s.kind = ShapeKind::kCapsule;
  s.p0 = a;
  s.p1 = b;
  s.r0 = radius;
  return s;
}

Shape MakeFrustum(Vec3 a, double radius_a, Vec3 b, double radius_b) {
  Shape s;
  s.kind = ShapeKind::kFrustum;
  s.p0 = a;
  s.p1 = b;
  s.r0 = radius_a;
  s.r1 = radius_b;
  return s;
}

Shape MakeBox(Vec3 centre, const Mat3& axes_as_columns, Vec3 half_extents) {
  Shape s;
  s.kind = ShapeKind::kBox;
  s.p0 = centre;
  s.frame = Transposed(axes_as_columns);
  s.half = half_extents;
  return s;
}

Shape MakeEllipsoid(Vec3 centre, const Mat3& axes_as_columns, Vec3 semi_axes) {
  Shape s = MakeBox(centre, axes_as_columns, semi_axes);
  s.kind = ShapeKind::kEllipsoid;
  return s;
}

Shape MakeRectangle(Vec3 centre, Vec3 u_axis, Vec3 v_axis, double half_u, double half_v) {
  Shape s;
  s.kind = ShapeKind::kRectangle;
  s.p0 = centre;
  s.frame = Transposed(Mat3::FromColumns(u_axis, v_axis, Cross(u_axis, v_axis)));
  s.half = {half_u, half_v, 0};
  return s;
}

bool IntersectShape(const Shape& s, const Ray& ray, double t_min, Hit* hit) {
  switch (s.kind) {
    case ShapeKind::kSphere:
      return IntersectSphere(s.p0, s.r0, ray, t_min, hit);
    case ShapeKind::kCapsule: {
      const Vec3 axis = s.p1 - s.p0;
      const double length = Norm(axis);
      bool found = false;
      if (length > 0) {
        found |= IntersectConeSide(s.p0, (1.0 / length) * axis, length, s.r0, 0.0, ray, t_min, hit);
      }
      found |= IntersectSphere(s.p0, s.r0, ray, t_min, hit);
      found |= IntersectSphere(s.p1, s.r0, ray, t_min, hit);
      return found;
    }
    case ShapeKind::kFrustum: {
      const Vec3 axis = s.p1 - s.p0;
      const double length = Norm(axis);
      const Vec3 u = (1.0 / length) * axis;
      bool found =
          IntersectConeSide(s.p0, u, length, s.r0, (s.r1 - s.r0) / length, ray, t_min, hit);
      found |= IntersectDisc(s.p0, -u, s.r0, ray, t_min, hit);
      found |= IntersectDisc(s.p1, u, s.r1, ray, t_min, hit);
      return found;
    }
    case ShapeKind::kBox: {
      const Vec3 o = s.frame.Apply(ray.origin - s.p0);
      const Vec3 d = s.frame.Apply(ray.direction);
      const std::array<double, 3> oo{o.x, o.y, o.z}, dd{d.x, d.y, d.z},
          hh{s.half.x, s.half.y, s.half.z};
      double t_near = -std::numeric_limits<double>::infinity();
      double t_far = std::numeric_limits<double>::infinity();
      int near_axis = -1;
      double near_sign = 0;
      for (int i = 0; i < 3; ++i) {
        if (std::fabs(dd[i]) < 1e-300) {
          if (std::fabs(oo[i]) > hh[i]) return false;
          continue;
        }
        double ta = (-hh[i] - oo[i]) / dd[i];
        double tb = (hh[i] - oo[i]) / dd[i];
        double sign = -1;
        if (ta > tb) {
          std::swap(ta, tb);
          sign = 1;
        }
        if (ta > t_near) {
          t_near = ta;
          near_axis = i;
          near_sign = sign;
        }
        t_far = std::min(t_far, tb);
      }
      if (t_near > t_far || near_axis < 0) return false;
      Vec3 local_normal;
      (near_axis == 0   ? local_normal.x
       : near_axis == 1 ? local_normal.y
                        : local_normal.z) = near_sign;
      return Accept(t_near, t_min, hit, s.frame.ApplyTransposed(local_normal), ray);
    }
    case ShapeKind::kEllipsoid: {
      const Vec3 ol = s.frame.Apply(ray.origin - s.p0);
      const Vec3 dl = s.frame.Apply(ray.direction);
      const Vec3 o{ol.x / s.half.x, ol.y / s.half.y, ol.z / s.half.z};
      const Vec3 d{dl.x / s.half.x, dl.y / s.half.y, dl.z / s.half.z};
      double t0, t1;
      if (!SolveQuadratic(Dot(d, d), Dot(o, d), Dot(o, o) - 1.0, &t0, &t1)) return false;
      for (double t : {t0, t1}) {
        if (!(t > t_min) || !(t < hit->t)) continue;
        const Vec3 p = o + t * d;
        const Vec3 local_normal{p.x / s.half.x, p.y / s.half.y, p.z / s.half.z};
        return Accept(t, t_min, hit, Normalized(s.frame.ApplyTransposed(local_normal)), ray);
      }
      return false;
    }
    case ShapeKind::kRectangle: {
      const Vec3 n = s.frame.r2;
      const double denom = Dot(n, ray.direction);
      if (std::fabs(denom) < 1e-300) return false;
      const double t = Dot(s.p0 - ray.origin, n) / denom;
      if (!(t > t_min) || !(t < hit->t)) return false;
      const Vec3 p = ray.origin + t * ray.direction - s.p0;
      if (std::fabs(Dot(p, s.frame.r0)) > s.half.x || std::fabs(Dot(p, s.frame.r1)) > s.half.y) {
        return false;
      }
      return Accept(t, t_min, hit, n, ray);
    }
  }
  return false;
}

double MinAlongDirection(const Shape& s, Vec3 w) {
  switch (s.kind) {
    case ShapeKind::kSphere:
      return Dot(w, s.p0) - s.r0 * Norm(w);
    case ShapeKind::kCapsule:
      return std::min(Dot(w, s.p0), Dot(w, s.p1)) - s.r0 * Norm(w);
    case ShapeKind::kFrustum: {
      const Vec3 u = Normalized(s.p1 - s.p0);
      const double wu = Dot(w, u);
      const double across = std::sqrt(std::max(0.0, Dot(w, w) - wu * wu));
      return std::min(Dot(w, s.p0) - s.r0 * across, Dot(w, s.p1) - s.r1 * across);
    }
    case ShapeKind::kBox:
      return Dot(w, s.p0) - s.half.x * std::fabs(Dot(s.frame.r0, w)) -
             s.half.y * std::fabs(Dot(s.frame.r1, w)) - s.half.z * std::fabs(Dot(s.frame.r2, w));
    case ShapeKind::kEllipsoid: {
      const Vec3 l = s.frame.Apply(w);
      const Vec3 scaled{s.half.x * l.x, s.half.y * l.y, s.half.z * l.z};
      return Dot(w, s.p0) - Norm(scaled);
    }
    case ShapeKind::kRectangle:
      return Dot(w, s.p0) - s.half.x * std::fabs(Dot(s.frame.r0, w)) -
             s.half.y * std::fabs(Dot(s.frame.r1, w));
  }
  return 0;
}

void ShapeBounds(const Shape& s, Vec3* lo, Vec3* hi) {
  // The extent along each world axis is -MinAlongDirection(-e) .. MinAlongDirection(e).
  const std::array<Vec3, 3> axes{Vec3{1, 0, 0}, Vec3{0, 1, 0}, Vec3{0, 0, 1}};
  std::array<double, 3> l{}, h{};
  for (int i = 0; i < 3; ++i) {
    l[i] = MinAlongDirection(s, axes[i]);
    h[i] = -MinAlongDirection(s, -axes[i]);
  }
  // A little slack against rounding in the slab tests.
  constexpr double kSlack = 1e-9;
  *lo = {l[0] - kSlack, l[1] - kSlack, l[2] - kSlack};
  *hi = {h[0] + kSlack, h[1] + kSlack, h[2] + kSlack};
}

int RayScene::Add(const Shape& shape) {
  LS_CHECK(!built_);
  shapes_.push_back(shape);
  return static_cast<int>(shapes_.size()) - 1;
}

void RayScene::SetGroundPlane(Vec3 normal, double offset, std::uint8_t surface_class) {
  has_ground_ = true;
  ground_normal_ = Normalized(normal);
  ground_offset_ = offset;
  ground_class_ = surface_class;
}

void RayScene::Build() {
  const int n = size();
  lo_.resize(n);
  hi_.resize(n);
  order_.resize(n);
  for (int i = 0; i < n; ++i) {
    ShapeBounds(shapes_[i], &lo_[i], &hi_[i]);
    order_[i] = i;
  }
  nodes_.clear();
  nodes_.reserve(2 * n + 1);
  if (n > 0) BuildNode(0, n);
  built_ = true;
}

int RayScene::BuildNode(int first, int count) {
  const int index = static_cast<int>(nodes_.size());
  nodes_.push_back({});
  Vec3 lo = lo_[order_[first]], hi = hi_[order_[first]];
  Vec3 centre_lo{1e300, 1e300, 1e300}, centre_hi{-1e300, -1e300, -1e300};
  for (int i = first; i < first + count; ++i) {
    const int s = order_[i];
    lo = Min(lo, lo_[s]);
    hi = Max(hi, hi_[s]);
    const Vec3 c = 0.5 * (lo_[s] + hi_[s]);
    centre_lo = Min(centre_lo, c);
    centre_hi = Max(centre_hi, c);
  }
  nodes_[index].lo = lo;
  nodes_[index].hi = hi;
  constexpr int kLeafSize = 3;
  if (count <= kLeafSize) {
    nodes_[index].first = first;
    nodes_[index].count = count;
    return index;
  }
  const Vec3 extent = centre_hi - centre_lo;
  const int axis = extent.x >= extent.y && extent.x >= extent.z ? 0 : extent.y >= extent.z ? 1 : 2;
  auto key = [&](int s) {
    const Vec3 c = lo_[s] + hi_[s];
    return axis == 0 ? c.x : axis == 1 ? c.y : c.z;
  };
  const int middle = first + count / 2;
  std::nth_element(order_.begin() + first, order_.begin() + middle, order_.begin() + first + count,
                   [&](int a, int b) { return key(a) < key(b) || (key(a) == key(b) && a < b); });
  const int left = BuildNode(first, middle - first);
  const int right = BuildNode(middle, first + count - middle);
  nodes_[index].left = left;
  nodes_[index].right = right;
  return index;
}

Hit RayScene::Intersect(const Ray& ray, double t_min) const {
  LS_CHECK(built_);
  Hit hit;
  if (has_ground_) {
    const double denom = Dot(ground_normal_, ray.direction);
    if (std::fabs(denom) > 1e-300) {
      const double t = (ground_offset_ - Dot(ground_normal_, ray.origin)) / denom;
      if (t > t_min) {
        hit.t = t;
        hit.normal = denom > 0 ? -ground_normal_ : ground_normal_;
        hit.shape = kGroundShape;
      }
    }
  }
  if (nodes_.empty()) return hit;
  const Vec3 inv{1.0 / ray.direction.x, 1.0 / ray.direction.y, 1.0 / ray.direction.z};
  constexpr double kInf = std::numeric_limits<double>::infinity();
  // Slab test; NaN from 0 * inf (a ray exactly on a slab plane) compares false and is ignored.
  auto box_entry = [&](const Node& node) {
    double t0 = (node.lo.x - ray.origin.x) * inv.x, t1 = (node.hi.x - ray.origin.x) * inv.x;
    double t_near = t0 < t1 ? t0 : t1, t_far = t0 < t1 ? t1 : t0;
    t0 = (node.lo.y - ray.origin.y) * inv.y;
    t1 = (node.hi.y - ray.origin.y) * inv.y;
    double lo = t0 < t1 ? t0 : t1, hi = t0 < t1 ? t1 : t0;
    t_near = lo > t_near ? lo : t_near;
    t_far = hi < t_far ? hi : t_far;
    t0 = (node.lo.z - ray.origin.z) * inv.z;
    t1 = (node.hi.z - ray.origin.z) * inv.z;
    lo = t0 < t1 ? t0 : t1;
    hi = t0 < t1 ? t1 : t0;
    t_near = lo > t_near ? lo : t_near;
    t_far = hi < t_far ? hi : t_far;
    if (t_far < t_near || t_far < t_min || t_near > hit.t) return kInf;
    return t_near;
  };
  struct Entry {
    int node;
    double t;
  };
  std::array<Entry, 64> stack;
  int top = 0;
  const double t_root = box_entry(nodes_[0]);
  if (t_root < kInf) stack[top++] = {0, t_root};
  while (top > 0) {
    const Entry entry = stack[--top];
    if (entry.t > hit.t) continue;  // a closer hit was found since it was pushed
    const Node& node = nodes_[entry.node];
    if (node.left < 0) {
      for (int i = node.first; i < node.first + node.count; ++i) {
        if (IntersectShape(shapes_[order_[i]], ray, t_min, &hit)) hit.shape = order_[i];
      }
      continue;
    }
    double t_left = box_entry(nodes_[node.left]);
    double t_right = box_entry(nodes_[node.right]);
    int first = node.left, second = node.right;
    if (t_right < t_left) {
      std::swap(first, second);
      std::swap(t_left, t_right);
    }
    // Push the farther child first so the nearer one is visited first.
    if (t_right < kInf) stack[top++] = {second, t_right};
    if (t_left < kInf) stack[top++] = {first, t_left};
    LS_CHECK(top < static_cast<int>(stack.size()) - 2);
  }
  return hit;
}

}  // namespace linesight::sim::detail
