#include "linesight/sim/plate_scene.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "linesight/core/error.h"

namespace linesight::sim {

void PlateRig::Check() const {
  CheckOption(image_size.width >= 32 && image_size.height >= 32, "PlateRig.image_size",
              fmt::format("{}x{}", image_size.width, image_size.height), "must be >= 32x32");
  CheckOption(focal_px > 0 && std::isfinite(focal_px), "PlateRig.focal_px", focal_px,
              "must be > 0");
  CheckOption(baseline_m > 0 && std::isfinite(baseline_m), "PlateRig.baseline_m", baseline_m,
              "must be > 0");
}

StereoCalibration PlateRig::Calibration() const {
  Check();
  return RectifiedPinholeCalibration(image_size, focal_px, 0.5 * (image_size.width - 1),
                                     0.5 * (image_size.height - 1), baseline_m);
}

std::string PlateShapeName(PlateShape shape) {
  switch (shape) {
    case PlateShape::kPlate:
      return "plate";
    case PlateShape::kSlantedPlate:
      return "slanted";
    case PlateShape::kBox:
      return "box";
  }
  return "?";
}

PlateShape ParsePlateShape(const std::string& text) {
  for (PlateShape s : {PlateShape::kPlate, PlateShape::kSlantedPlate, PlateShape::kBox}) {
    if (PlateShapeName(s) == text) return s;
  }
  throw UsageError(fmt::format("unknown shape '{}' (expected plate, slanted or box)", text));
}

void PlateSceneSpec::Check() const {
  rig.Check();
  CheckOption(distance_m >= 0.1 && distance_m <= 100, "PlateSceneSpec.distance_m", distance_m,
              "must be in [0.1, 100] m");
  CheckOption(size_m.width > 0 && size_m.height > 0, "PlateSceneSpec.size_m",
              fmt::format("{}x{}", size_m.width, size_m.height), "must be positive");
  CheckOption(box_depth_m > 0, "PlateSceneSpec.box_depth_m", box_depth_m, "must be > 0");
  CheckOption(std::abs(slant_rad) < 1.3, "PlateSceneSpec.slant_rad", slant_rad,
              "must be in (-1.3, 1.3) rad");
  CheckOption(background_m == 0.0 || background_m > distance_m + box_depth_m,
              "PlateSceneSpec.background_m", background_m,
              "must be 0 (automatic) or behind the object");
  CheckOption(supersampling >= 1 && supersampling <= 8, "PlateSceneSpec.supersampling",
              supersampling, "must be in [1, 8]");
  CheckOption(!plate_texture.empty() && plate_texture.depth() == CV_8U,
              "PlateSceneSpec.plate_texture", plate_texture.empty() ? "empty" : "not 8-bit",
              "must be an 8-bit image");
  CheckOption(!background_texture.empty() && background_texture.depth() == CV_8U,
              "PlateSceneSpec.background_texture",
              background_texture.empty() ? "empty" : "not 8-bit", "must be an 8-bit image");
}

namespace {

// A mip-mapped texture: level 0 is the photograph as CV_32FC3 in [0, 1]; level k is cv::pyrDown
// of level k - 1. Lookups wrap around (the photograph tiles the face).
class MipTexture {
 public:
  explicit MipTexture(const cv::Mat& image) {
    cv::Mat bgr;
    if (image.channels() == 1) {
      cv::cvtColor(image, bgr, cv::COLOR_GRAY2BGR);
    } else if (image.channels() == 4) {
      cv::cvtColor(image, bgr, cv::COLOR_BGRA2BGR);
    } else {
      bgr = image;
    }
    cv::Mat level;
    bgr.convertTo(level, CV_32FC3, 1.0 / 255.0);
    levels_.push_back(level);
    while (std::min(levels_.back().cols, levels_.back().rows) >= 16) {
      cv::Mat next;
      cv::pyrDown(levels_.back(), next);
      levels_.push_back(next);
    }
  }

  int width() const { return levels_.front().cols; }

  // Colour at texel coordinates (u, v) of level 0 for a footprint of `texels` level-0 texels.
  cv::Vec3f Sample(double u, double v, double texels) const {
    const double lod =
        std::clamp(std::log2(std::max(texels, 1.0)), 0.0, static_cast<double>(levels_.size() - 1));
    const int l0 = static_cast<int>(std::floor(lod));
    const double t = lod - l0;
    const cv::Vec3f a = Bilinear(l0, u, v);
    if (t <= 0.0 || l0 + 1 >= static_cast<int>(levels_.size())) return a;
    const cv::Vec3f b = Bilinear(l0 + 1, u, v);
    return a * static_cast<float>(1.0 - t) + b * static_cast<float>(t);
  }

 private:
  cv::Vec3f Bilinear(int level, double u, double v) const {
    const cv::Mat& m = levels_[static_cast<size_t>(level)];
    const double scale = std::ldexp(1.0, -level);
    const double x = u * scale - 0.5, y = v * scale - 0.5;
    const double fx = std::floor(x), fy = std::floor(y);
    const float ax = static_cast<float>(x - fx), ay = static_cast<float>(y - fy);
    auto wrap = [](double value, int n) {
      const long long i = static_cast<long long>(value) % n;
      return static_cast<int>(i < 0 ? i + n : i);
    };
    const int x0 = wrap(fx, m.cols), x1 = (x0 + 1) % m.cols;
    const int y0 = wrap(fy, m.rows), y1 = (y0 + 1) % m.rows;
    const cv::Vec3f* r0 = m.ptr<cv::Vec3f>(y0);
    const cv::Vec3f* r1 = m.ptr<cv::Vec3f>(y1);
    return (r0[x0] * (1.0f - ax) + r0[x1] * ax) * (1.0f - ay) +
           (r1[x0] * (1.0f - ax) + r1[x1] * ax) * ay;
  }

  std::vector<cv::Mat> levels_;
};

// A textured rectangle origin + s * u_axis + t * v_axis, 0 <= s <= width, 0 <= t <= height
// (infinite when width / height are +inf: the wall). Texel (s + s0, t + t0) / texel_m.
struct Face {
  cv::Vec3d origin, u_axis, v_axis, normal;
  double width = 0.0, height = 0.0;
  const MipTexture* texture = nullptr;
  double texel_m = 0.0;
  double s0 = 0.0, t0 = 0.0;
  bool object = false;
  float shade = 1.0f;  // Lambert-like factor per face, so that the box's faces differ in brightness
};

struct Hit {
  double z = std::numeric_limits<double>::infinity();
  const Face* face = nullptr;
  double s = 0.0, t = 0.0, cos_incidence = 1.0;
};

Hit Intersect(const std::vector<Face>& faces, const cv::Vec3d& centre, const cv::Vec3d& dir) {
  Hit best;
  double best_t = std::numeric_limits<double>::infinity();
  for (const Face& f : faces) {
    const double denom = f.normal.dot(dir);
    if (std::abs(denom) < 1e-12) continue;
    const double t = f.normal.dot(f.origin - centre) / denom;
    if (!(t > 1e-9) || t >= best_t) continue;
    const cv::Vec3d p = centre + t * dir - f.origin;
    const double s = p.dot(f.u_axis), q = p.dot(f.v_axis);
    if (s < 0.0 || s > f.width || q < 0.0 || q > f.height) continue;
    best_t = t;
    best.z = centre[2] + t * dir[2];
    best.face = &f;
    best.s = s;
    best.t = q;
    best.cos_incidence = std::abs(denom) / cv::norm(dir);
  }
  return best;
}

std::vector<Face> BuildFaces(const PlateSceneSpec& spec, const MipTexture& object_texture,
                             const MipTexture& wall_texture) {
  const double f = spec.rig.focal_px;
  const double cx = 0.5 * (spec.rig.image_size.width - 1);
  const double cy = 0.5 * (spec.rig.image_size.height - 1);
  const double d = spec.distance_m;
  const double w = spec.size_m.width, h = spec.size_m.height;
  const double wall_z = spec.background_m > 0.0 ? spec.background_m : 1.5 * spec.distance_m + 1.0;
  // Front face centre on the ray through centre_px at depth d (for the slanted plate: its near
  // edge at depth d, so its centre is farther).
  const double x_centre = (spec.centre_px.x - cx) / f * d;
  const double y_centre = (spec.centre_px.y - cy) / f * d;
  const double object_texel = w / object_texture.width();
  std::vector<Face> faces;
  auto add = [&](cv::Vec3d origin, cv::Vec3d u, cv::Vec3d v, double fw, double fh, double s0,
                 float shade) {
    Face face;
    face.origin = origin;
    face.u_axis = u;
    face.v_axis = v;
    face.normal = u.cross(v);
    face.width = fw;
    face.height = fh;
    face.texture = &object_texture;
    face.texel_m = object_texel;
    face.s0 = s0;
    face.object = true;
    face.shade = shade;
    faces.push_back(face);
  };
  const cv::Vec3d ex(1, 0, 0), ey(0, 1, 0), ez(0, 0, 1);
  switch (spec.shape) {
    case PlateShape::kPlate:
      add({x_centre - 0.5 * w, y_centre - 0.5 * h, d}, ex, ey, w, h, 0.0, 1.0f);
      break;
    case PlateShape::kSlantedPlate: {
      // Turned by slant_rad about the vertical axis: u = (cos a, 0, sin a). The near edge is the
      // one at s = 0 for a > 0; place it at depth d.
      const double a = spec.slant_rad;
      const cv::Vec3d u(std::cos(a), 0.0, std::sin(a));
      const cv::Vec3d near_edge =
          a >= 0 ? cv::Vec3d(x_centre - 0.5 * w * std::cos(a), y_centre - 0.5 * h, d)
                 : cv::Vec3d(x_centre - 0.5 * w * std::cos(a), y_centre - 0.5 * h,
                             d - w * std::sin(a));
      add(near_edge, u, ey, w, h, 0.0, 0.95f);
      break;
    }
    case PlateShape::kBox: {
      const double depth = spec.box_depth_m;
      const cv::Vec3d corner(x_centre - 0.5 * w, y_centre - 0.5 * h, d);
      add(corner, ex, ey, w, h, 0.0, 1.0f);                    // front
      add(corner, ez, ey, depth, h, 0.37 * w, 0.7f);           // left side
      add(corner + w * ex, ez, ey, depth, h, 0.61 * w, 0.8f);  // right side
      add(corner, ex, ez, w, depth, 0.23 * w, 0.85f);          // top
      add(corner + h * ey, ex, ez, w, depth, 0.71 * w, 0.6f);  // bottom
      break;
    }
  }
  // The wall: about 1.2 image pixels per texel at its depth (a photograph seen at its own scale).
  Face wall;
  wall.u_axis = ex;
  wall.v_axis = ey;
  wall.normal = ez;
  wall.width = wall.height = std::numeric_limits<double>::infinity();
  wall.origin = {-1e6, -1e6, wall_z};
  wall.texture = &wall_texture;
  wall.texel_m = 1.2 * wall_z / f;
  wall.shade = 0.9f;
  faces.push_back(wall);
  return faces;
}

void RenderView(const PlateSceneSpec& spec, const std::vector<Face>& faces, double camera_x,
                cv::Mat* radiance) {
  const cv::Size size = spec.rig.image_size;
  const double f = spec.rig.focal_px;
  const double cx = 0.5 * (size.width - 1), cy = 0.5 * (size.height - 1);
  const int ss = spec.supersampling;
  radiance->create(size, CV_32FC3);
  const cv::Vec3d centre(camera_x, 0.0, 0.0);
  cv::parallel_for_(cv::Range(0, size.height), [&](const cv::Range& rows) {
    for (int y = rows.start; y < rows.end; ++y) {
      cv::Vec3f* out = radiance->ptr<cv::Vec3f>(y);
      for (int x = 0; x < size.width; ++x) {
        cv::Vec3f sum(0, 0, 0);
        for (int j = 0; j < ss; ++j) {
          for (int i = 0; i < ss; ++i) {
            // Sub-sample (i, j) of pixel (x, y): pixel centres at integer coordinates.
            const double u = x - 0.5 + (i + 0.5) / ss, v = y - 0.5 + (j + 0.5) / ss;
            // The right camera sits at +B: its pixel u sees the ray (u - cx) / f from there.
            const cv::Vec3d dir((u - cx) / f, (v - cy) / f, 1.0);
            const Hit hit = Intersect(faces, centre, dir);
            if (!hit.face) continue;
            const Face& face = *hit.face;
            const double footprint_m = hit.z / (f * ss) / std::max(hit.cos_incidence, 0.2);
            const cv::Vec3f c =
                face.texture->Sample((hit.s + face.s0) / face.texel_m,
                                     (hit.t + face.t0) / face.texel_m, footprint_m / face.texel_m);
            sum += c * face.shade;
          }
        }
        out[x] = sum * (1.0f / static_cast<float>(ss * ss));
      }
    }
  });
}

}  // namespace

PlateRendering RenderPlateScene(const PlateSceneSpec& spec) {
  spec.Check();
  const MipTexture object_texture(spec.plate_texture), wall_texture(spec.background_texture);
  const std::vector<Face> faces = BuildFaces(spec, object_texture, wall_texture);
  PlateRendering r;
  RenderView(spec, faces, 0.0, &r.left);
  RenderView(spec, faces, spec.rig.baseline_m, &r.right);

  const cv::Size size = spec.rig.image_size;
  const double f = spec.rig.focal_px;
  const double cx = 0.5 * (size.width - 1), cy = 0.5 * (size.height - 1);
  r.depth_gt.create(size, CV_32FC1);
  r.disparity_gt.create(size, CV_32FC1);
  r.object_mask = cv::Mat::zeros(size, CV_8UC1);
  double nearest = std::numeric_limits<double>::infinity();
  for (int y = 0; y < size.height; ++y) {
    for (int x = 0; x < size.width; ++x) {
      const Hit hit = Intersect(faces, {0, 0, 0}, {(x - cx) / f, (y - cy) / f, 1.0});
      r.depth_gt.at<float>(y, x) = static_cast<float>(hit.z);
      r.disparity_gt.at<float>(y, x) = static_cast<float>(f * spec.rig.baseline_m / hit.z);
      if (hit.face && hit.face->object) {
        r.object_mask.at<uint8_t>(y, x) = 255;
        nearest = std::min(nearest, hit.z);
      }
    }
  }
  if (!std::isfinite(nearest)) {
    throw InputError(fmt::format(
        "plate scene: the {} at {} m is not in the image (centre {},{} px)",
        PlateShapeName(spec.shape), spec.distance_m, spec.centre_px.x, spec.centre_px.y));
  }
  r.distance_m = nearest;
  r.box = cv::boundingRect(r.object_mask);
  return r;
}

cv::Mat CapturePlateImage(const cv::Mat& radiance, double noise_dn, std::uint64_t seed) {
  LS_CHECK(radiance.type() == CV_32FC3);
  cv::Mat dn = radiance * 255.0;
  if (noise_dn > 0) {
    cv::Mat noise(dn.size(), CV_32FC3);
    cv::RNG rng(seed);
    rng.fill(noise, cv::RNG::NORMAL, 0.0, noise_dn);
    dn += noise;
  }
  cv::Mat out;
  dn.convertTo(out, CV_8UC3);  // rounds and saturates
  return out;
}

}  // namespace linesight::sim
