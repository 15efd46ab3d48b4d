#include "linesight/sim/power_line_scene.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <numbers>
#include <numeric>

#include <fmt/format.h>
#include <opencv2/calib3d.hpp>

#include "linesight/core/disparity.h"
#include "linesight/core/error.h"
#include "linesight/io/image_io.h"
#include "linesight/io/json_io.h"
#include "linesight/io/pfm.h"
#include "linesight/sim/camera_model.h"
#include "linesight/sim/procedural_texture.h"
#include "linesight/sim/scene_render.h"
#include "linesight/sim/sensor_model.h"
#include "linesight/sim/sim_internal.h"

namespace linesight::sim {

using detail::Mat3;
using detail::Vec3;

// ----------------------------------------------------------------------------------------------
// Rig and options
// ----------------------------------------------------------------------------------------------

cv::Matx33d CameraIntrinsics::CameraMatrix() const { return {fx, 0, cx, 0, fy, cy, 0, 0, 1}; }

cv::Mat CameraIntrinsics::DistortionCoefficients() const {
  cv::Mat d(1, 5, CV_64F);
  for (int i = 0; i < 5; ++i) d.at<double>(0, i) = distortion[i];
  return d;
}

namespace {

void CheckIntrinsics(const CameraIntrinsics& c, const std::string& name, cv::Size size) {
  auto field = [&](const char* f) { return name + "." + f; };
  CheckOption(c.fx >= 50 && c.fx <= 20000, field("fx").c_str(), c.fx, "must be in [50, 20000] px");
  CheckOption(c.fy >= 50 && c.fy <= 20000, field("fy").c_str(), c.fy, "must be in [50, 20000] px");
  CheckOption(c.cx >= 0 && c.cx <= size.width, field("cx").c_str(), c.cx,
              "must lie inside the image width");
  CheckOption(c.cy >= 0 && c.cy <= size.height, field("cy").c_str(), c.cy,
              "must lie inside the image height");
  const char* names[5] = {"k1", "k2", "p1", "p2", "k3"};
  const double limits[5] = {0.5, 0.5, 0.02, 0.02, 0.5};
  for (int i = 0; i < 5; ++i) {
    CheckOption(std::isfinite(c.distortion[i]) && std::fabs(c.distortion[i]) <= limits[i],
                field((std::string("distortion.") + names[i]).c_str()).c_str(), c.distortion[i],
                "must be a small lens distortion (|k| <= 0.5, |p| <= 0.02)");
  }
}

}  // namespace

void StereoRigOptions::Check() const {
  CheckOption(image_size.width >= 64 && image_size.height >= 48 && image_size.width <= 8192 &&
                  image_size.height <= 8192,
              "StereoRigOptions.image_size",
              fmt::format("{}x{}", image_size.width, image_size.height),
              "must be between 64x48 and 8192x8192");
  CheckIntrinsics(left, "StereoRigOptions.left", image_size);
  CheckIntrinsics(right, "StereoRigOptions.right", image_size);
  const double angle = cv::norm(right_from_left_rotation);
  CheckOption(angle <= 0.2, "StereoRigOptions.right_from_left_rotation", angle,
              "rotation angle must be <= 0.2 rad (a stereo rig, cameras nearly parallel)");
  const cv::Vec3d& t = right_from_left_translation;
  const double baseline = cv::norm(t);
  CheckOption(baseline >= 0.01 && baseline <= 2.0, "StereoRigOptions.right_from_left_translation",
              baseline, "baseline |T| must be in [0.01, 2] m");
  CheckOption(t[0] < 0 && std::fabs(t[0]) > 0.9 * baseline,
              "StereoRigOptions.right_from_left_translation.x", t[0],
              "must be negative and dominate T (the right camera is to the right of the left one)");
}

StereoCalibration MakeStereoCalibration(const StereoRigOptions& rig) {
  rig.Check();
  StereoCalibration calib;
  calib.image_size = rig.image_size;
  calib.M1 = cv::Mat(rig.left.CameraMatrix()).clone();
  calib.D1 = rig.left.DistortionCoefficients();
  calib.M2 = cv::Mat(rig.right.CameraMatrix()).clone();
  calib.D2 = rig.right.DistortionCoefficients();
  cv::Rodrigues(cv::Mat(rig.right_from_left_rotation), calib.R);
  calib.T = cv::Mat(rig.right_from_left_translation).clone();
  const cv::Vec3d& t = rig.right_from_left_translation;
  const cv::Matx33d tx(0, -t[2], t[1], t[2], 0, -t[0], -t[1], t[0], 0);
  const cv::Matx33d r(calib.R);
  const cv::Matx33d e = tx * r;
  calib.E = cv::Mat(e).clone();
  const cv::Matx33d f = rig.right.CameraMatrix().inv().t() * e * rig.left.CameraMatrix().inv();
  calib.F = cv::Mat(f * (1.0 / f(2, 2))).clone();
  cv::stereoRectify(calib.M1, calib.D1, calib.M2, calib.D2, calib.image_size, calib.R, calib.T,
                    calib.R1, calib.R2, calib.P1, calib.P2, calib.Q, cv::CALIB_ZERO_DISPARITY, 0.0,
                    calib.image_size);
  return calib;
}

void SensorOptions::Check() const {
  CheckOption(supersampling >= 1 && supersampling <= 8, "SensorOptions.supersampling",
              supersampling, "must be in [1, 8]");
  CheckOption(exposure > 0 && exposure <= 100, "SensorOptions.exposure", exposure,
              "must be in (0, 100]");
  CheckOption(right_gain > 0 && right_gain <= 10, "SensorOptions.right_gain", right_gain,
              "must be in (0, 10]");
  CheckOption(gamma >= 1 && gamma <= 3, "SensorOptions.gamma", gamma, "must be in [1, 3]");
  CheckOption(vignetting >= 0 && vignetting <= 0.9, "SensorOptions.vignetting", vignetting,
              "must be in [0, 0.9]");
  CheckOption(blur_sigma_px >= 0 && blur_sigma_px <= 10, "SensorOptions.blur_sigma_px",
              blur_sigma_px, "must be in [0, 10] px");
  CheckOption(noise_sigma_dn >= 0 && noise_sigma_dn <= 64, "SensorOptions.noise_sigma_dn",
              noise_sigma_dn, "must be in [0, 64] DN");
  CheckOption(
      shot_noise_electrons == 0 || (shot_noise_electrons >= 10 && shot_noise_electrons <= 1e7),
      "SensorOptions.shot_noise_electrons", shot_noise_electrons,
      "must be 0 (off) or in [10, 1e7] electrons at full scale");
}

std::string ObstacleTypeName(ObstacleType type) {
  switch (type) {
    case ObstacleType::kDamper:
      return "damper";
    case ObstacleType::kSuspensionClamp:
      return "clamp";
    case ObstacleType::kInsulatorString:
      return "insulator";
  }
  return "unknown";
}

ObstacleType ParseObstacleType(std::string_view name) {
  if (name == "damper" || name == "counterweight" || name == "stockbridge") {
    return ObstacleType::kDamper;
  }
  if (name == "clamp" || name == "suspension_clamp") return ObstacleType::kSuspensionClamp;
  if (name == "insulator" || name == "insulator_string") return ObstacleType::kInsulatorString;
  throw InputError(
      fmt::format("unknown obstacle type '{}': expected damper, clamp or insulator", name));
}

std::vector<ObstacleType> AllObstacleTypes() {
  return {ObstacleType::kDamper, ObstacleType::kSuspensionClamp, ObstacleType::kInsulatorString};
}

std::vector<ObstacleSpec> ParseObstacleSpecs(std::string_view text) {
  std::vector<ObstacleSpec> specs;
  if (text.empty()) return specs;
  size_t start = 0;
  while (start <= text.size()) {
    const size_t end = std::min(text.find(',', start), text.size());
    const std::string entry(text.substr(start, end - start));
    start = end + 1;
    std::vector<std::string> parts;
    size_t p = 0;
    while (true) {
      const size_t colon = entry.find(':', p);
      parts.push_back(entry.substr(p, colon == std::string::npos ? std::string::npos : colon - p));
      if (colon == std::string::npos) break;
      p = colon + 1;
    }
    if (parts.size() < 2 || parts.size() > 3) {
      throw InputError(fmt::format(
          "obstacle '{}': expected type:distance_m[:conductor], e.g. damper:1.5", entry));
    }
    ObstacleSpec spec;
    try {
      spec.type = ParseObstacleType(parts[0]);
    } catch (const InputError& e) {
      throw InputError(fmt::format("obstacle '{}': {}", entry, e.what()));
    }
    auto parse_number = [&](const std::string& s, const char* what) {
      size_t used = 0;
      double value = 0;
      try {
        value = std::stod(s, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used != s.size() || s.empty() || !std::isfinite(value)) {
        throw InputError(fmt::format("obstacle '{}': {} '{}' is not a number", entry, what, s));
      }
      return value;
    };
    spec.distance_m = parse_number(parts[1], "distance");
    if (parts.size() == 3) {
      const double conductor = parse_number(parts[2], "conductor index");
      if (conductor != std::floor(conductor) || conductor < 0 || conductor > 16) {
        throw InputError(
            fmt::format("obstacle '{}': conductor index must be an integer >= 0", entry));
      }
      spec.conductor = static_cast<int>(conductor);
    }
    specs.push_back(spec);
    if (end == text.size()) break;
  }
  return specs;
}

void PowerLineSceneOptions::Check() const {
  rig.Check();
  sensor.Check();
  CheckOption(num_conductors >= 1 && num_conductors <= 4, "PowerLineSceneOptions.num_conductors",
              num_conductors, "must be in [1, 4]");
  CheckOption(obstacles.size() <= 255, "PowerLineSceneOptions.obstacles", obstacles.size(),
              "at most 255 obstacles (8-bit id mask)");
  for (size_t i = 0; i < obstacles.size(); ++i) {
    const ObstacleSpec& o = obstacles[i];
    const std::string name = fmt::format("PowerLineSceneOptions.obstacles[{}]", i);
    CheckOption(std::isfinite(o.distance_m) && o.distance_m >= 0.2 && o.distance_m <= 80,
                (name + ".distance_m").c_str(), o.distance_m, "must be in [0.2, 80] m");
    CheckOption(o.distance_m < 0.9 * span_ahead_m, (name + ".distance_m").c_str(), o.distance_m,
                "must be shorter than 0.9 * span_ahead_m (the conductor ends at the next tower)");
    CheckOption(o.conductor >= 0 && o.conductor < num_conductors, (name + ".conductor").c_str(),
                o.conductor, "must be a conductor index in [0, num_conductors)");
  }
  CheckOption(std::fabs(conductor_offset_x_m) <= 2, "PowerLineSceneOptions.conductor_offset_x_m",
              conductor_offset_x_m, "must be in [-2, 2] m");
  CheckOption(std::fabs(conductor_offset_y_m) <= 2 &&
                  std::hypot(conductor_offset_x_m, conductor_offset_y_m) > 2 * conductor_radius_m,
              "PowerLineSceneOptions.conductor_offset_y_m", conductor_offset_y_m,
              "must be in [-2, 2] m and keep the conductor clear of the camera");
  CheckOption(conductor_radius_m >= 0.002 && conductor_radius_m <= 0.05,
              "PowerLineSceneOptions.conductor_radius_m", conductor_radius_m,
              "must be in [0.002, 0.05] m");
  CheckOption(conductor_spacing_m >= 4 * conductor_radius_m && conductor_spacing_m <= 10,
              "PowerLineSceneOptions.conductor_spacing_m", conductor_spacing_m,
              "must be in [4 * conductor_radius_m, 10] m");
  CheckOption(std::isfinite(tower_offset_x_m) && std::fabs(tower_offset_x_m) <= 20,
              "PowerLineSceneOptions.tower_offset_x_m", tower_offset_x_m, "must be in [-20, 20] m");
  CheckOption(std::fabs(conductor_yaw_rad) <= 0.5, "PowerLineSceneOptions.conductor_yaw_rad",
              conductor_yaw_rad, "must be in [-0.5, 0.5] rad");
  CheckOption(std::fabs(conductor_pitch_rad) <= 0.5, "PowerLineSceneOptions.conductor_pitch_rad",
              conductor_pitch_rad, "must be in [-0.5, 0.5] rad");
  CheckOption(sag_parameter_m >= 50 && sag_parameter_m <= 1e6,
              "PowerLineSceneOptions.sag_parameter_m", sag_parameter_m, "must be in [50, 1e6] m");
  CheckOption(span_ahead_m >= 10 && span_ahead_m <= 1000, "PowerLineSceneOptions.span_ahead_m",
              span_ahead_m, "must be in [10, 1000] m");
  CheckOption(conductor_strands >= 6 && conductor_strands <= 60,
              "PowerLineSceneOptions.conductor_strands", conductor_strands, "must be in [6, 60]");
  CheckOption(conductor_lay_length_m >= 0.02 && conductor_lay_length_m <= 2,
              "PowerLineSceneOptions.conductor_lay_length_m", conductor_lay_length_m,
              "must be in [0.02, 2] m");
  CheckOption(ground_depth_m >= 1 && ground_depth_m <= 200, "PowerLineSceneOptions.ground_depth_m",
              ground_depth_m, "must be in [1, 200] m");
  CheckOption(cloud_cover >= 0 && cloud_cover <= 1, "PowerLineSceneOptions.cloud_cover",
              cloud_cover, "must be in [0, 1]");
  CheckOption(sun_elevation_deg >= 5 && sun_elevation_deg <= 90,
              "PowerLineSceneOptions.sun_elevation_deg", sun_elevation_deg,
              "must be in [5, 90] deg");
  CheckOption(sun_azimuth_deg >= -180 && sun_azimuth_deg <= 180,
              "PowerLineSceneOptions.sun_azimuth_deg", sun_azimuth_deg,
              "must be in [-180, 180] deg");
  CheckOption(ambient >= 0 && ambient <= 1, "PowerLineSceneOptions.ambient", ambient,
              "must be in [0, 1]");
}

// ----------------------------------------------------------------------------------------------
// Scene construction
// ----------------------------------------------------------------------------------------------

namespace detail {

Mat3 FromCv(const cv::Matx33d& m) {
  return {{m(0, 0), m(0, 1), m(0, 2)}, {m(1, 0), m(1, 1), m(1, 2)}, {m(2, 0), m(2, 1), m(2, 2)}};
}

Mat3 Multiply(const Mat3& a, const Mat3& b) {
  const Vec3 c0 = a.Apply({b.r0.x, b.r1.x, b.r2.x});
  const Vec3 c1 = a.Apply({b.r0.y, b.r1.y, b.r2.y});
  const Vec3 c2 = a.Apply({b.r0.z, b.r1.z, b.r2.z});
  return Mat3::FromColumns(c0, c1, c2);
}

CameraIntrinsics RectifiedIntrinsics(const StereoCalibration& calib) {
  CameraIntrinsics k;
  k.fx = calib.P1.at<double>(0, 0);
  k.fy = calib.P1.at<double>(1, 1);
  k.cx = calib.P1.at<double>(0, 2);
  k.cy = calib.P1.at<double>(1, 2);
  return k;
}

RigPoses MakeRigPoses(const StereoCalibration& calib, const Mat3& left_from_world) {
  RigPoses poses;
  const Mat3 right_from_left = FromCv(cv::Matx33d(calib.R));
  const Vec3 t{calib.T.at<double>(0), calib.T.at<double>(1), calib.T.at<double>(2)};
  poses.left = PosedCamera::FromRt(left_from_world, {0, 0, 0});
  poses.right = PosedCamera::FromRt(Multiply(right_from_left, left_from_world), t);
  const Mat3 rect_from_left = FromCv(cv::Matx33d(calib.R1));
  const Mat3 rect_from_world = Multiply(rect_from_left, left_from_world);
  poses.rectified_left = PosedCamera::FromRt(rect_from_world, {0, 0, 0});
  // Both rectified cameras share the orientation R1 (= R2 * R); the right one sits at the true
  // right camera centre.
  poses.rectified_right =
      PosedCamera::FromRt(rect_from_world, -1.0 * rect_from_world.Apply(poses.right.centre));
  return poses;
}

void CreateOutputDirectory(const std::filesystem::path& dir) {
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  if (error || !std::filesystem::is_directory(dir)) {
    throw InputError(fmt::format("cannot create output folder '{}': {}", dir.string(),
                                 error ? error.message() : "not a directory"));
  }
}

}  // namespace detail

namespace {

using detail::MakeBox;
using detail::MakeCapsule;
using detail::MakeEllipsoid;
using detail::MakeFrustum;
using detail::Material;
using detail::Shape;

constexpr std::uint8_t kClassGround = static_cast<std::uint8_t>(SurfaceClass::kGround);
constexpr std::uint8_t kClassTower = static_cast<std::uint8_t>(SurfaceClass::kTower);
constexpr std::uint8_t kClassConductor = static_cast<std::uint8_t>(SurfaceClass::kConductor);
constexpr std::uint8_t kClassObstacle = static_cast<std::uint8_t>(SurfaceClass::kObstacle);

Mat3 RotationX(double a) {
  return {{1, 0, 0}, {0, std::cos(a), -std::sin(a)}, {0, std::sin(a), std::cos(a)}};
}
Mat3 RotationY(double a) {
  return {{std::cos(a), 0, std::sin(a)}, {0, 1, 0}, {-std::sin(a), 0, std::cos(a)}};
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

// Local frame of an obstacle at arc position `arc` on conductor c: along the line, down
// (perpendicular to it, in the vertical plane) and lateral.
struct LocalFrame {
  Vec3 origin, along, down, side;
  Vec3 At(double a, double d, double l) const { return origin + a * along + d * down + l * side; }
  Mat3 Axes() const { return Mat3::FromColumns(along, down, side); }
};

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

Shape Tagged(Shape s, Material material, std::uint8_t surface_class, int obstacle_id,
             double texture_seed) {
  s.material = material;
  s.surface_class = surface_class;
  s.obstacle_id = static_cast<std::uint8_t>(obstacle_id);
  s.texture_seed = texture_seed;
  return s;
}

// A cable texture needs the arc offset at p0 and a reference direction perpendicular to its axis.
Shape Cable(Shape s, double arc_offset) {
  const Vec3 axis = detail::Normalized(s.p1 - s.p0);
  const Vec3 x{1, 0, 0};
  s.reference = detail::Normalized(x - Dot(x, axis) * axis);
  s.arc_offset = arc_offset;
  return s;
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

struct VisibleStats {
  double min_depth = std::numeric_limits<double>::infinity();
  cv::Point nearest{-1, -1};
  cv::Rect box;
  int pixels = 0;
};

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
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return options.obstacles[a].distance_m < options.obstacles[b].distance_m;
  });
  const double radius = options.conductor_radius_m;
  const Vec3 w = poses.rectified_left.camera_from_scene.r2;
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
      AddObstacle(spec.type, FrameOnConductor(line, spec.conductor, arc), radius, id, &shapes);
      return shapes;
    };
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

  cv::Mat depth, surface_class, ids;
  detail::TraceGroundTruth(scene, rect_k, poses.rectified_left, size,
                           cv::Rect(0, 0, size.width, size.height), &depth, &surface_class, &ids);
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
    result.obstacles.push_back(o);
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
                    {"visible_pixels", o.visible_pixels}});
  }
  return {{"distance_definition", detail::kDistanceDefinition}, {"obstacles", list}};
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
  if (!scene.rectified_left.empty()) {
    WriteImage(dir / "rectified_left.png", scene.rectified_left);
    WriteImage(dir / "rectified_right.png", scene.rectified_right);
  }
}

}  // namespace linesight::sim
