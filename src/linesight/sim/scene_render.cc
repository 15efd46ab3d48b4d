#include "linesight/sim/scene_render.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "linesight/sim/procedural_texture.h"

namespace linesight::sim::detail {
namespace {

double Smoothstep(double a, double b, double x) {
  const double t = std::clamp((x - a) / (b - a), 0.0, 1.0);
  return t * t * (3.0 - 2.0 * t);
}

Vec3 Mix(Vec3 a, Vec3 b, double t) { return a + t * (b - a); }
Vec3 Modulate(Vec3 a, Vec3 b) { return {a.x * b.x, a.y * b.y, a.z * b.z}; }

Vec3 SkyRadiance(const ShadingEnvironment& env, Vec3 direction) {
  const double elevation = Dot(direction, env.up);  // sine of the elevation
  const Vec3 horizon{0.78, 0.82, 0.88};
  const Vec3 zenith{0.28, 0.45, 0.78};
  Vec3 sky = Mix(horizon, zenith, std::sqrt(std::max(0.0, elevation)));
  if (elevation > 0.01 && env.cloud_cover > 0) {
    // Clouds on a layer 1 km up, textured in metres on that layer.
    const double to_layer = 1000.0 / elevation;
    const Vec3 p = to_layer * direction;
    const Vec3 on_layer = p - Dot(p, env.up) * env.up;
    const Vec3 q = (1.0 / 700.0) * on_layer;
    const double density = FractalNoise(q, 6, env.seed + 101);
    const double threshold = 1.0 - env.cloud_cover;
    double cover = Smoothstep(threshold - 0.12, threshold + 0.18, density);
    cover *= Smoothstep(0.01, 0.12, elevation);  // clouds thin out towards the horizon haze
    const double shade = 0.78 + 0.22 * FractalNoise(2.3 * q, 4, env.seed + 202);
    sky = Mix(sky, Vec3{0.93, 0.93, 0.95} * shade, cover);
  }
  return sky;
}

// Helical strand pattern of a cable at point p on a capsule/frustum shape.
double StrandProfile(const Shape& shape, Vec3 p, int strands, double lay_length,
                     std::uint64_t seed) {
  const Vec3 axis = Normalized(shape.p1 - shape.p0);
  const Vec3 rel = p - shape.p0;
  const double along = Dot(rel, axis);
  const Vec3 radial = rel - along * axis;
  const Vec3 e1 = shape.reference;
  const Vec3 e2 = Cross(axis, e1);
  const double angle = std::atan2(Dot(radial, e2), Dot(radial, e1));
  const double arc = shape.arc_offset + along;
  const double phase = strands * (angle / (2.0 * std::numbers::pi) + arc / lay_length);
  const double f = phase - std::floor(phase);
  // Rounded strand: bright crest, dark groove between neighbouring strands.
  const double crest = std::sqrt(std::max(0.0, std::sin(std::numbers::pi * f)));
  const auto strand_index = static_cast<std::int64_t>(std::floor(phase));
  const double per_strand =
      0.9 + 0.2 * LatticeHash(((strand_index % strands) + strands) % strands, 0, 0, seed);
  return (0.45 + 0.55 * crest) * per_strand;
}

// Birdcage: the conductor's helix continued onto the bulge (same phase, per-wire brightness and
// dirt, so it joins the conductor's texture), every wire keeping its width while the circumference
// grows: dark gaps open between the loosened wires onto the inner layer, laid the other way.
Vec3 BirdcageAlbedo(const ShadingEnvironment& env, const Shape& shape, Vec3 p, std::uint64_t seed) {
  const Vec3 axis = shape.frame.r0;
  const Vec3 rel = p - shape.p0;
  const double along = Dot(rel, axis);
  const Vec3 radial = rel - along * axis;
  const Vec3 e1 = shape.reference;
  const Vec3 e2 = Cross(axis, e1);
  const double turn = std::atan2(Dot(radial, e2), Dot(radial, e1)) / (2.0 * std::numbers::pi);
  const double arc = shape.arc_offset + along;
  const int strands = env.conductor_strands;
  const double phase = strands * (turn + arc / env.conductor_lay_length_m);
  const auto index = static_cast<std::int64_t>(std::floor(phase));
  const std::int64_t strand = ((index % strands) + strands) % strands;
  const double f = phase - std::floor(phase);
  const double width = std::clamp(shape.r0 / std::max(Norm(radial), 1e-9), 0.2, 1.0);
  const double dirt = 0.78 + 0.3 * FractalNoise(45.0 * p, 4, seed + 11);
  const double opened = 1.0 - 0.3 * (1.0 - width);  // weathered inside, exposed by the opening
  // Each wire wanders inside its widened slot.
  const double centre = 0.5 + (LatticeHash(strand, 1, 0, seed) - 0.5) * (1.0 - width);
  const double x = (f - centre) / (0.5 * width);
  if (std::fabs(x) < 1.0) {
    const double crest = std::sqrt(std::max(0.0, std::cos(0.5 * std::numbers::pi * x)));
    const double per_strand = 0.9 + 0.2 * LatticeHash(strand, 0, 0, seed);
    return Vec3{0.56, 0.57, 0.58} * ((0.45 + 0.55 * crest) * per_strand * dirt * opened);
  }
  const double inner_phase = (strands - 6) * (turn - arc / env.conductor_lay_length_m);
  const double inner = std::sqrt(
      std::max(0.0, std::sin(std::numbers::pi * (inner_phase - std::floor(inner_phase)))));
  return Vec3{0.30, 0.30, 0.29} * ((0.25 + 0.45 * inner) * dirt);
}

// Bird's nest: a 3D tangle of straight twigs, 4 mm thick, in four directions. For each direction
// space is cut into cells across it; a cell holds a twig (centre jittered within the cell) in
// segments of random presence along it, so a surface shows long streaks where it runs along a
// direction and dots where it cuts across. The brightest twig wins; between twigs lies dark shadow.
Vec3 NestAlbedo(Vec3 p, std::uint64_t seed) {
  struct TwigAxes {
    Vec3 along, u, v;
  };
  static const auto kAxes = [] {
    std::array<TwigAxes, 4> axes;
    const Vec3 directions[] = {
        {1.0, 0.25, 0.15}, {0.2, 0.3, 1.0}, {-0.6, 0.35, 0.7}, {0.7, -0.45, -0.5}};
    for (int k = 0; k < 4; ++k) {
      const Vec3 d = Normalized(directions[k]);
      const Vec3 helper = std::fabs(d.y) < 0.9 ? Vec3{0, 1, 0} : Vec3{1, 0, 0};
      const Vec3 u = Normalized(Cross(d, helper));
      axes[k] = {d, u, Cross(d, u)};
    }
    return axes;
  }();
  constexpr double kCellsPerMetre = 250.0;  // 4 mm twigs
  constexpr double kSegmentCells = 14.0;    // twig pieces about 5.6 cm long
  double best = 0.0;
  double tone = 0.0;
  for (int k = 0; k < 4; ++k) {
    const TwigAxes& axes = kAxes[k];
    const double x = kCellsPerMetre * Dot(p, axes.along);
    const double a = kCellsPerMetre * Dot(p, axes.u), b = kCellsPerMetre * Dot(p, axes.v);
    const auto ia = static_cast<std::int64_t>(std::floor(a));
    const auto ib = static_cast<std::int64_t>(std::floor(b));
    const std::uint64_t twig_seed = seed + 500 + 17 * k;
    const double shift = kSegmentCells * LatticeHash(ia, ib, -1, twig_seed);
    const auto segment = static_cast<std::int64_t>(std::floor((x + shift) / kSegmentCells));
    const double presence = LatticeHash(ia, ib, segment, twig_seed + 1);
    if (presence > 0.6) continue;
    const double ca = 0.5 + 0.3 * (LatticeHash(ia, ib, segment, twig_seed + 2) - 0.5);
    const double cb = 0.5 + 0.3 * (LatticeHash(ia, ib, segment, twig_seed + 3) - 0.5);
    const double da = a - static_cast<double>(ia) - ca, db = b - static_cast<double>(ib) - cb;
    const double r2 = (da * da + db * db) / (0.42 * 0.42);
    if (r2 >= 1.0) continue;
    const double shade = std::sqrt(1.0 - r2) * (0.7 + 0.5 * presence);
    if (shade > best) {
      best = shade;
      tone = LatticeHash(ia, ib, segment, twig_seed + 4);
    }
  }
  // Dry brown and weathered grey twigs, some straw.
  Vec3 colour = Mix(Vec3{0.33, 0.24, 0.15}, Vec3{0.42, 0.40, 0.37}, Smoothstep(0.5, 0.8, tone));
  if (tone > 0.85) colour = Vec3{0.62, 0.54, 0.33};
  const double grain = 0.8 + 0.3 * FractalNoise(600.0 * p, 2, seed + 510);
  return colour * ((0.15 + 0.85 * best) * grain);
}

Vec3 Albedo(const RenderScene& scene, const Shape& shape, Vec3 p) {
  const ShadingEnvironment& env = scene.environment;
  const std::uint64_t seed = env.seed + static_cast<std::uint64_t>(shape.texture_seed * 1000.0);
  switch (shape.material) {
    case Material::kConductor: {
      const double strands =
          StrandProfile(shape, p, env.conductor_strands, env.conductor_lay_length_m, seed);
      const double dirt = 0.78 + 0.3 * FractalNoise(45.0 * p, 4, seed + 11);
      return Vec3{0.56, 0.57, 0.58} * (strands * dirt);
    }
    case Material::kMessenger: {
      const double strands = StrandProfile(shape, p, 7, 0.09, seed);
      return Vec3{0.34, 0.33, 0.31} * (strands * (0.8 + 0.3 * FractalNoise(60.0 * p, 3, seed)));
    }
    case Material::kCastAluminium: {
      const double grain = FractalNoise(110.0 * p, 5, seed + 21);
      const double spots = Smoothstep(0.62, 0.72, FractalNoise(35.0 * p, 3, seed + 22));
      return Vec3{0.66, 0.66, 0.63} * (0.62 + 0.5 * grain - 0.25 * spots);
    }
    case Material::kGalvanised: {
      const double spangle = LatticeHash(static_cast<std::int64_t>(std::floor(180.0 * p.x)),
                                         static_cast<std::int64_t>(std::floor(180.0 * p.y)),
                                         static_cast<std::int64_t>(std::floor(180.0 * p.z)), seed);
      const double grain = FractalNoise(90.0 * p, 4, seed + 31);
      return Vec3{0.52, 0.54, 0.55} * (0.6 + 0.35 * grain + 0.15 * spangle);
    }
    case Material::kDamperWeight: {
      const double grain = FractalNoise(80.0 * p, 5, seed + 41);
      const double rust = Smoothstep(0.6, 0.75, FractalNoise(20.0 * p, 3, seed + 42));
      return Mix(Vec3{0.40, 0.41, 0.42}, Vec3{0.42, 0.27, 0.15}, 0.6 * rust) * (0.55 + 0.6 * grain);
    }
    case Material::kGlass: {
      const double grain = FractalNoise(50.0 * p, 4, seed + 51);
      return Vec3{0.10, 0.24, 0.20} * (0.6 + 0.7 * grain);
    }
    case Material::kTowerSteel: {
      const double grain = FractalNoise(4.0 * p, 3, seed + 61);
      return Vec3{0.46, 0.47, 0.48} * (0.7 + 0.4 * grain);
    }
    case Material::kChessboard: {
      const Vec3 local = shape.frame.Apply(p - shape.p0);
      // The rectangle centre sits in the middle of the squares; shift to the first inner corner.
      const double x =
          (local.x + 0.5 * (env.board_cols - 1) * env.board_square_m) / env.board_square_m;
      const double y =
          (local.y + 0.5 * (env.board_rows - 1) * env.board_square_m) / env.board_square_m;
      const bool inside = x >= -1 && x <= env.board_cols && y >= -1 && y <= env.board_rows;
      const Vec3 white{0.82, 0.82, 0.80};
      if (!inside) return white;
      const auto cx = static_cast<std::int64_t>(std::floor(x));
      const auto cy = static_cast<std::int64_t>(std::floor(y));
      const bool black = ((cx + cy) % 2 + 2) % 2 == 0;
      return black ? Vec3{0.035, 0.035, 0.04} : white;
    }
    case Material::kWall: {
      const double grain = FractalNoise(6.0 * p, 3, seed + 81);
      return Vec3{0.42, 0.40, 0.37} * (0.7 + 0.5 * grain);
    }
    case Material::kBirdcage:
      return BirdcageAlbedo(env, shape, p, seed);
    case Material::kLooseStrand: {
      const double grain = FractalNoise(220.0 * p, 3, seed + 71);
      return Vec3{0.62, 0.63, 0.64} * (0.7 + 0.4 * grain);
    }
    case Material::kRope: {
      // Three twisted strands of a synthetic rope in one of a few faded colours.
      static constexpr Vec3 kColours[] = {{0.55, 0.13, 0.10},
                                          {0.13, 0.22, 0.48},
                                          {0.70, 0.38, 0.08},
                                          {0.16, 0.30, 0.16},
                                          {0.09, 0.09, 0.09}};
      const auto pick = static_cast<size_t>(LatticeHash(0, 0, 0, seed + 301) * 5.0);
      const double strands = StrandProfile(shape, p, 3, 0.02, seed);
      const double fibres = 0.8 + 0.3 * FractalNoise(400.0 * p, 2, seed + 302);
      return kColours[std::min<size_t>(pick, 4)] * (strands * fibres);
    }
    case Material::kPlasticSheet: {
      // Light film with creases (ridges of a noise field) and a little dirt.
      static constexpr Vec3 kColours[] = {
          {0.86, 0.86, 0.84}, {0.62, 0.74, 0.84}, {0.80, 0.80, 0.66}, {0.74, 0.76, 0.76}};
      const auto pick = static_cast<size_t>(LatticeHash(0, 0, 0, seed + 401) * 4.0);
      const double fold = FractalNoise(18.0 * p, 3, seed + 402);
      const double crease = std::pow(1.0 - std::fabs(2.0 * fold - 1.0), 8.0);
      const double dirt = Smoothstep(0.6, 0.8, FractalNoise(9.0 * p, 3, seed + 403));
      const double grain = FractalNoise(90.0 * p, 2, seed + 404);
      return kColours[std::min<size_t>(pick, 3)] *
             (0.86 + 0.12 * grain - 0.22 * crease - 0.25 * dirt);
    }
    case Material::kNest:
      return NestAlbedo(p, seed);
  }
  return {0.5, 0.5, 0.5};
}

Vec3 GroundAlbedo(const ShadingEnvironment& env, Vec3 p) {
  const Vec3 on_ground = p - Dot(p, env.up) * env.up;
  const double fields = FractalNoise((1.0 / 35.0) * on_ground, 4, env.seed + 91);
  const double detail = FractalNoise((1.0 / 1.5) * on_ground, 4, env.seed + 92);
  const double tufts = FractalNoise(4.0 * on_ground, 2, env.seed + 93);
  const Vec3 grass{0.16, 0.25, 0.08}, dry{0.36, 0.33, 0.17}, soil{0.30, 0.23, 0.15};
  Vec3 albedo = Mix(grass, dry, Smoothstep(0.4, 0.65, fields));
  albedo = Mix(albedo, soil, 0.5 * Smoothstep(0.6, 0.8, detail));
  return albedo * (0.7 + 0.35 * detail + 0.15 * tufts);
}

}  // namespace

Vec3 Shade(const RenderScene& scene, const Ray& ray, const Hit& hit) {
  const ShadingEnvironment& env = scene.environment;
  if (hit.shape == -1) return env.sky ? SkyRadiance(env, ray.direction) : env.backdrop;
  const Vec3 p = ray.origin + hit.t * ray.direction;
  const Vec3 albedo = hit.shape == RayScene::kGroundShape
                          ? GroundAlbedo(env, p)
                          : Albedo(scene, scene.geometry.shape(hit.shape), p);
  const double direct = std::max(0.0, Dot(hit.normal, env.to_sun));
  const double sky_view = 0.6 + 0.4 * Dot(hit.normal, env.up);  // up-facing surfaces see more sky
  const double light = env.ambient * sky_view + (1.0 - env.ambient) * direct * 1.1;
  const Vec3 tint{1.0, 0.98, 0.95};
  return Modulate(albedo, tint) * light;
}

namespace {

cv::Vec3f ToBgr(Vec3 rgb, double scale) {
  return cv::Vec3f(static_cast<float>(rgb.z * scale), static_cast<float>(rgb.y * scale),
                   static_cast<float>(rgb.x * scale));
}

// Marks thin cables and members that may fall between pixel centres, so they get supersampled.
void MarkThinStructures(const RenderScene& scene, const CameraIntrinsics& intrinsics,
                        const PosedCamera& camera, cv::Mat* refine) {
  for (int i = 0; i < scene.geometry.size(); ++i) {
    const Shape& shape = scene.geometry.shape(i);
    if (shape.kind != ShapeKind::kCapsule && shape.kind != ShapeKind::kFrustum) continue;
    const Vec3 a = camera.camera_from_scene.Apply(shape.p0) + camera.translation;
    const Vec3 b = camera.camera_from_scene.Apply(shape.p1) + camera.translation;
    if (a.z < 0.05 || b.z < 0.05) continue;  // near the camera a cable is wide anyway
    const double radius_px = intrinsics.fx * std::max(shape.r0, shape.r1) / std::min(a.z, b.z);
    if (radius_px > 2.0) continue;
    double ua, va, ub, vb;
    if (!ProjectPoint(intrinsics, a, &ua, &va) || !ProjectPoint(intrinsics, b, &ub, &vb)) continue;
    const double limit = 1e5;
    if (std::fabs(ua) > limit || std::fabs(va) > limit || std::fabs(ub) > limit ||
        std::fabs(vb) > limit) {
      continue;
    }
    cv::line(
        *refine,
        cv::Point(static_cast<int>(std::lround(ua * 16)), static_cast<int>(std::lround(va * 16))),
        cv::Point(static_cast<int>(std::lround(ub * 16)), static_cast<int>(std::lround(vb * 16))),
        cv::Scalar(1), 3 + static_cast<int>(2 * radius_px), cv::LINE_8, 4);
  }
}

}  // namespace

cv::Mat RenderLinearImage(const RenderScene& scene, const CameraIntrinsics& intrinsics,
                          const PosedCamera& camera, cv::Size size, int supersampling) {
  // Pass 1: one ray through every pixel centre.
  cv::Mat image(size, CV_32FC3);
  cv::Mat shape_index(size, CV_32SC1);
  cv::parallel_for_(
      cv::Range(0, size.height),
      [&](const cv::Range& rows) {
        for (int v = rows.start; v < rows.end; ++v) {
          auto* out = image.ptr<cv::Vec3f>(v);
          auto* index = shape_index.ptr<int>(v);
          for (int u = 0; u < size.width; ++u) {
            const Ray ray = camera.RayThrough(PixelRay(intrinsics, u, v));
            const Hit hit = scene.geometry.Intersect(ray);
            out[u] = ToBgr(Shade(scene, ray, hit), 1.0);
            index[u] = hit.shape;
          }
        }
      },
      size.height / 4.0);
  const int s = supersampling;
  if (s == 1) return image;

  // Pass 2: supersample where it matters: silhouettes (a neighbour shows another shape), every
  // shape with fine texture (all but the ground, sky and the wall) and thin structures.
  cv::Mat refine = cv::Mat::zeros(size, CV_8UC1);
  for (int v = 0; v < size.height; ++v) {
    const auto* index = shape_index.ptr<int>(v);
    const auto* colour = image.ptr<cv::Vec3f>(v);
    auto* mark = refine.ptr<unsigned char>(v);
    for (int u = 0; u < size.width; ++u) {
      const int id = index[u];
      const Material material = id >= 0 ? scene.geometry.shape(id).material : Material::kWall;
      // Flat-coloured regions (sky, ground, wall, chessboard squares) only need it at edges:
      // another shape, or for the chessboard another colour, next door.
      const bool flat = id < 0 || material == Material::kWall || material == Material::kChessboard;
      bool needed = !flat;
      for (int dv = -1; dv <= 1 && !needed; ++dv) {
        const int vv = v + dv;
        if (vv < 0 || vv >= size.height) continue;
        const auto* row = shape_index.ptr<int>(vv);
        const auto* row_colour = image.ptr<cv::Vec3f>(vv);
        for (int du = -1; du <= 1; ++du) {
          const int uu = u + du;
          if (uu < 0 || uu >= size.width) continue;
          if (row[uu] != id || (material == Material::kChessboard &&
                                std::fabs(row_colour[uu][1] - colour[u][1]) > 0.1f)) {
            needed = true;
            break;
          }
        }
      }
      mark[u] = needed ? 1 : 0;
    }
  }
  MarkThinStructures(scene, intrinsics, camera, &refine);
  const double inv_count = 1.0 / (s * s);
  cv::parallel_for_(
      cv::Range(0, size.height),
      [&](const cv::Range& rows) {
        for (int v = rows.start; v < rows.end; ++v) {
          auto* out = image.ptr<cv::Vec3f>(v);
          const auto* mark = refine.ptr<unsigned char>(v);
          for (int u = 0; u < size.width; ++u) {
            if (!mark[u]) continue;
            Vec3 sum;
            for (int j = 0; j < s; ++j) {
              for (int i = 0; i < s; ++i) {
                const double su = u + (i + 0.5) / s - 0.5, sv = v + (j + 0.5) / s - 0.5;
                const Ray ray = camera.RayThrough(PixelRay(intrinsics, su, sv));
                sum = sum + Shade(scene, ray, scene.geometry.Intersect(ray));
              }
            }
            out[u] = ToBgr(sum, inv_count);
          }
        }
      },
      size.height / 4.0);
  return image;
}

void TraceGroundTruth(const RenderScene& scene, const CameraIntrinsics& pinhole,
                      const PosedCamera& camera, cv::Size size, cv::Rect roi, cv::Mat* depth,
                      cv::Mat* surface_class, cv::Mat* obstacle_id, cv::Mat* defect_id) {
  depth->create(size, CV_32FC1);
  depth->setTo(std::numeric_limits<float>::infinity());
  surface_class->create(size, CV_8UC1);
  surface_class->setTo(0);
  obstacle_id->create(size, CV_8UC1);
  obstacle_id->setTo(0);
  if (defect_id != nullptr) {
    defect_id->create(size, CV_8UC1);
    defect_id->setTo(0);
  }
  roi &= cv::Rect(0, 0, size.width, size.height);
  if (roi.empty()) return;
  cv::parallel_for_(
      cv::Range(roi.y, roi.y + roi.height),
      [&](const cv::Range& rows) {
        for (int v = rows.start; v < rows.end; ++v) {
          auto* z = depth->ptr<float>(v);
          auto* cls = surface_class->ptr<unsigned char>(v);
          auto* id = obstacle_id->ptr<unsigned char>(v);
          auto* defect = defect_id != nullptr ? defect_id->ptr<unsigned char>(v) : nullptr;
          for (int u = roi.x; u < roi.x + roi.width; ++u) {
            const Vec3 direction =
                Normalized({(u - pinhole.cx) / pinhole.fx, (v - pinhole.cy) / pinhole.fy, 1.0});
            const Ray ray = camera.RayThrough(direction);
            const Hit hit = scene.geometry.Intersect(ray);
            if (hit.shape == -1) continue;
            z[u] = static_cast<float>(hit.t * direction.z);
            if (hit.shape == RayScene::kGroundShape) {
              cls[u] = scene.geometry.GroundClass();
            } else {
              const Shape& shape = scene.geometry.shape(hit.shape);
              cls[u] = shape.surface_class;
              id[u] = shape.obstacle_id;
              if (defect != nullptr) defect[u] = shape.defect_id;
            }
          }
        }
      },
      roi.height / 4.0);
}

}  // namespace linesight::sim::detail
