// Synthetic power-line scenes with exact ground truth.
//
// A stereo rig modelled on the MYNT S1030 (752x480, fx ~ 736 px, baseline ~ 119 mm, plumb-bob
// distortion, slightly misaligned cameras) looks along a power-line conductor from a robot riding
// below it. Obstacles sit on the line at chosen distances: a Stockbridge damper ("damper"), a
// suspension clamp ("clamp") and an insulator string ("insulator"). Background: sky gradient with
// clouds, lattice towers with a neighbouring line, textured terrain.
//
// Rendering is ray casting through each camera's *distorted* model: every raw pixel is undistorted
// to a ray (Newton iterations to ~1e-15 in normalised coordinates) that is intersected with
// analytic geometry (spheres, capsules, capped cones, boxes, ellipsoids, planes; the sagging
// conductor is a chain of capsules along a catenary). Anti-aliasing: S x S rays per pixel wherever
// it matters (silhouettes, every textured object, thin cables and lattice members); flat sky/ground
// interiors take one ray. Shading is Lambertian (sun + sky ambient) and every texture is defined in
// 3D world/object coordinates, so a surface point has the same colour in both views. The default
// pair with ground truth costs about 2 CPU-seconds (about 1 s on 2 cores).
//
// Ground truth is ray cast with the same geometry through the RECTIFIED left camera (P1, R1 of the
// true calibration, filled by cv::stereoRectify with alpha 0 and CALIB_ZERO_DISPARITY), one ray
// through each pixel centre (OpenCV convention: pixel (u, v) is centred on integer coordinates), so
// it is exact (to float rounding of the stored maps):
//   depth(v, u)     = Z of the hit point in the rectified left camera frame (metres),
//   disparity(v, u) = f * B / Z, f = P1(0,0), B = -P2(0,3) / P2(0,0) (pixels, rectified images),
// and +inf where the ray hits nothing (sky).
//
// Frames: "left"/"right" are the raw camera frames (x right, y down, z forward, metres), "rect" the
// rectified left camera frame: X_rect = R1 * X_left. The true extrinsic is right_from_left:
// X_right = R * X_left + T. Internally the scene lives in a gravity-aligned world frame centred on
// the left camera, which is pitched with the slope of the conductor.
//
// Obstacle distance (what ranging must reproduce): the distance from the left camera centre to the
// obstacle's nearest surface AS SEEN, measured along the RECTIFIED left optical axis, i.e. the
// minimum of the ground-truth depth Z_rect over the obstacle's visible pixels (pixel centres of the
// rectified left image, occlusion by the conductor or other obstacles and the image border taken
// into account). Each obstacle is slid along its conductor until that minimum equals the requested
// distance (to 1e-4 m; the achieved value is what `distance_m` reports). `surface_min_depth_m` is
// the minimum of Z_rect over the obstacle's WHOLE surface (analytic); it is smaller than
// `distance_m` only when the nearest part is hidden or outside the image, which happens at very
// short range. Obstacles are designed with a camera-facing front (damper weight end caps, clamp
// body face, insulator disc rims), so the nearest surface is a patch, not a single point.
//
// Defects (DefectSpec) sit on conductor 0 at a given arc: damage to the conductor itself (a
// "birdcage", where the outer strands have spread into a bulge, and broken outer strands whose cut
// ends stand off the surface; SurfaceClass::kConductor) and foreign objects caught on it (a hanging
// string, a plastic sheet, a bird's nest on top; SurfaceClass::kObstacle). They are not obstacles:
// their pixels carry their id in PowerLineScene::defect_mask, never in obstacle_mask, and their
// truth (RenderedDefect) gives their extent along the line, size, nearest visible depth and box. A
// defect hides what is behind it, so it takes part in the placement of the obstacles like the
// conductor does. Without defects (the default) nothing of the scene changes.
//
// Everything is deterministic: the same options (including the seed) give identical bytes on every
// run and any number of threads.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "linesight/io/stereo_calibration.h"

namespace linesight::sim {

// ----------------------------------------------------------------------------------------------------------
// Camera rig
// ----------------------------------------------------------------------------------------------------------

// One pinhole camera with plumb-bob distortion (OpenCV order k1 k2 p1 p2 k3).
struct CameraIntrinsics {
  double fx = 736.0;                                          // focal length along x (px)
  double fy = 736.0;                                          // focal length along y (px)
  double cx = 376.0;                                          // principal point x (px)
  double cy = 240.0;                                          // principal point y (px)
  std::array<double, 5> distortion{0.0, 0.0, 0.0, 0.0, 0.0};  // k1 k2 p1 p2 k3 (dimensionless)

  cv::Matx33d CameraMatrix() const;
  cv::Mat DistortionCoefficients() const;  // 1x5 CV_64F
};

// Stereo rig modelled on the MYNT S1030: both cameras differ slightly in focal length and principal
// point, lenses have small radial/tangential distortion, and the right camera is rotated by a
// fraction of a degree and offset a little in y/z so that rectification matters.
struct StereoRigOptions {
  cv::Size image_size{752, 480};  // width x height (px)
  CameraIntrinsics left{736.2, 735.4, 378.3, 238.6, {-0.048, 0.061, 0.00031, -0.00024, 0.0}};
  CameraIntrinsics right{738.1, 737.6, 372.9, 242.2, {-0.052, 0.067, -0.00018, 0.00027, 0.0}};
  // right_from_left rotation as a Rodrigues vector (rad): about 0.25 deg tilt, 0.3 deg pan, 0.2 deg
  // roll.
  cv::Vec3d right_from_left_rotation{0.0044, -0.0052, 0.0035};
  // right_from_left translation (m): X_right = R * X_left + T; the baseline is ~ |T| = 119 mm.
  cv::Vec3d right_from_left_translation{-0.11898, 0.0011, -0.0007};

  void Check() const;  // OptionError naming the field
};

// The true calibration of the rig: M1 D1 M2 D2 R T E F, and R1 R2 P1 P2 Q from cv::stereoRectify
// with alpha = 0 and CALIB_ZERO_DISPARITY.
StereoCalibration MakeStereoCalibration(const StereoRigOptions& rig);

// ----------------------------------------------------------------------------------------------------------
// Sensor model (shared by scenes and calibration boards)
// ----------------------------------------------------------------------------------------------------------

struct SensorOptions {
  int supersampling = 3;    // S: S x S rays per raw pixel for anti-aliasing, 1..8
  double exposure = 1.0;    // multiplies scene radiance before encoding (> 0); 1 = nominal
  double right_gain = 1.0;  // extra gain of the right camera relative to the left (> 0)
  double gamma = 2.2;       // encoding gamma: DN = 255 * (exposure * L)^(1/gamma), 1 = linear
  double vignetting = 0.0;  // relative fall-off at the image corner: gain = 1 - v * (r/r_corner)^2
  double blur_sigma_px = 0.0;   // Gaussian optical blur of the raw images (px), 0 = none
  double noise_sigma_dn = 1.0;  // additive Gaussian read noise (DN, 8-bit scale), 0 = none
  // > 0 enables shot noise: full scale (255 DN) collects this many electrons; 0 = no shot noise.
  double shot_noise_electrons = 0.0;
  // Seed of the sensor noise; unset = derived from the scene/board seed. Set it to take fresh noise
  // on the same scene (the noise-free image does not depend on it).
  std::optional<std::uint64_t> noise_seed;

  void Check() const;
};

// ----------------------------------------------------------------------------------------------------------
// Power-line scene
// ----------------------------------------------------------------------------------------------------------

enum class ObstacleType {
  // Stockbridge damper ("counterweight"): clamp on the conductor, messenger cable below it and two
  // dumbbell weights whose flat end caps face along the line.
  kDamper,
  // Suspension clamp: box-shaped body around the conductor, keeper with U-bolts, short hanger.
  kSuspensionClamp,
  // Insulator string: a suspension clamp hanging from a vertical stack of glass disc sheds that
  // hangs
  // from a crossarm (the crossarm counts as tower, not as the obstacle).
  kInsulatorString,
};

// "damper", "clamp", "insulator".
std::string ObstacleTypeName(ObstacleType type);
// Accepts the names above (also "counterweight", "stockbridge", "suspension_clamp",
// "insulator_string"); throws InputError listing the valid names.
ObstacleType ParseObstacleType(std::string_view name);
std::vector<ObstacleType> AllObstacleTypes();

struct ObstacleSpec {
  ObstacleType type = ObstacleType::kDamper;
  double distance_m = 1.5;  // requested true distance (see the file comment), 0.2..80 m
  int conductor = 0;        // index of the conductor it sits on (0 = the one the robot rides)
  // Set: the obstacle's centre sits at this arc length along its conductor (m, from the point of
  // conductor 0 nearest to the left camera centre, see PowerLineScene::conductor_axis) and
  // distance_m is not
  // used; the distance it has is measured (+inf when no pixel of it is visible). This is how a
  // moving sequence places its obstacles. In [-5, 0.9 * span_ahead_m].
  std::optional<double> arc_m;
  // A damaged damper: turned about the conductor's axis by this angle (deg, -60..60; 0 = its
  // weights hang straight down, > 0 swings them towards +x of the line's frame, to the right seen
  // from the robot). Only dampers may be tilted.
  double tilt_deg = 0.0;
};

// Extent of an obstacle of `type` along its conductor, relative to its centre (m): {behind, ahead},
// behind < 0 < ahead. The near end of an obstacle centred at arc s lies at s + behind.
std::array<double, 2> ObstacleAlongExtent(ObstacleType type);

// "damper:1.5,clamp:3,insulator:4.5,damper:2:tilt=15" (type:distance_m[:conductor][:tilt=deg],
// comma separated). Throws InputError naming the offending entry.
std::vector<ObstacleSpec> ParseObstacleSpecs(std::string_view text);

// Defects of conductor 0 (see the top of the file).
enum class DefectType {
  // Birdcage: the outer strands have opened into a bulge around the line (an ellipsoid around the
  // axis with loose, gapped strands showing the dark inner layer).
  kBirdcage,
  // Broken strands: cut outer strands leave the surface and stand off it at their free ends.
  kBrokenStrands,
  // A string or rope wrapped around the conductor, hanging from it.
  kHangingString,
  // A plastic sheet wrapped over the conductor, hanging from it.
  kPlasticSheet,
  // A bird's nest sitting on top of the conductor.
  kBirdNest,
};

// "birdcage", "broken_strands", "string", "sheet", "nest".
std::string DefectTypeName(DefectType type);
// Accepts the names above (also "broken-strands", "hanging_string", "plastic_sheet",
// "bird_nest"); throws InputError listing the valid names.
DefectType ParseDefectType(std::string_view name);
std::vector<DefectType> AllDefectTypes();

struct DefectSpec {
  DefectType type = DefectType::kBirdcage;
  // Arc length of its centre along conductor 0 (m; same origin as ObstacleSpec::arc_m: 0 = the
  // point of conductor 0 nearest the left camera centre), in [-50, 0.9 * span_ahead_m].
  double arc_m = 2.0;
  // Birdcage: radius increase relative to the conductor radius, 0.05..1.0.
  double swelling = 0.3;
  // Birdcage: length along the line (0.03..0.5 m); string: hanging length (0.03..1.5 m); sheet:
  // side of the (square-ish) sheet (0.03..0.6 m); nest: diameter (0.05..0.6 m).
  double length_m = 0.15;
  int strands = 1;  // broken strands: number of cut outer strands, 1..3
  // Broken strands: how far the cut ends stand off the conductor surface (m), 0.002..0.08.
  double standoff_m = 0.01;
  // Direction around the line (deg, -360..360) in which the broken strands stick out and in which
  // the string and the sheet hang: 0 = straight down (gravity side), 90 = to the side, 180 = up.
  // A birdcage is round and a nest always sits on top, so they ignore it.
  double angle_deg = 0.0;
};

// "birdcage:2.0:swelling=0.3:length=0.15,string:3.1:length=0.4,broken_strands:2.5:strands=2"
// (type:arc_m[:key=value]..., comma separated). Keys: birdcage swelling, length; broken_strands
// strands, standoff, angle; string length, angle; sheet length (or side), angle; nest length (or
// diameter). Values are range-checked as in PowerLineSceneOptions::Check (but for the arc, whose
// range depends on the span). Throws InputError naming the offending entry, key or value.
std::vector<DefectSpec> ParseDefectSpecs(std::string_view text);

// `count` defects (0..255) with types, arcs and sizes drawn from `seed`, sorted by arc: arcs in
// [min_arc_m, max_arc_m] at least 0.5 m apart (they are not kept clear of obstacles); birdcage
// swelling 0.1..0.5 and length 0.05..0.3 m; broken strands 1..3 strands, standoff 0.003..0.05 m,
// angle 0..360 deg; string length 0.05..0.6 m; sheet side 0.05..0.4 m; string and sheet within +-30
// deg of straight down; nest diameter 0.15..0.4 m. Throws InputError when `count` defects 0.5 m
// apart do not fit into the range.
std::vector<DefectSpec> RandomDefects(std::uint64_t seed, int count, double min_arc_m,
                                      double max_arc_m);

struct PowerLineSceneOptions {
  StereoRigOptions rig;
  SensorOptions sensor;
  // Scene variation (textures, clouds, terrain) and the default noise seed.
  std::uint64_t seed = 1;

  // Obstacles in the default scene: three types spread out along the line.
  std::vector<ObstacleSpec> obstacles{{ObstacleType::kDamper, 1.5, 0},
                                      {ObstacleType::kSuspensionClamp, 3.0, 0},
                                      {ObstacleType::kInsulatorString, 4.5, 0}};
  // Defects on conductor 0 (see the top of the file); none by default. At most 255 (8-bit id
  // mask).
  std::vector<DefectSpec> defects;

  // Conductors. The robot rides below conductor 0, so the camera sees it passing just above and
  // beside the lens: at z = 0 its axis is at (conductor_offset_x_m, conductor_offset_y_m) in the
  // left frame. It runs away from the camera along +z (turned by yaw and pitch) and sags as a
  // catenary with its lowest point half-way to the next tower, `span_ahead_m` ahead, where it ends.
  // The other conductors are parallel to it, spaced along x.
  //
  // Default mounting: the line passes 0.10 m left of and 0.10 m above the left camera and the
  // rig is turned towards it, so the line heads 0.30 rad to the right and crosses in front of the
  // lenses: an obstacle on it at 0.3 m lies in both views (looking along the line, yaw -0.10, an
  // obstacle at 0.3 m is left of the right camera's view). The line stays left of both
  // cameras (its perpendicular offset is -0.095 m), so both see the same side of it, leaning the
  // same way in both images: with the line above the middle of the baseline (x = 0.06) the two
  // views see it from opposite sides, its image leans left in one view and right in the other,
  // and isgm and sgbm lose it and the obstacles on it from 3.5 m on (`eval ranging`, README).
  int num_conductors = 2;  // 1..4
  // x of conductor 0's axis at z = 0 (m).
  double conductor_offset_x_m = -0.10;
  // y of conductor 0's axis at z = 0 (m; +y is down, so < 0 is above the camera).
  double conductor_offset_y_m = -0.10;
  // x spacing between neighbouring conductors (m), >= 4 conductor radii.
  double conductor_spacing_m = 3.5;
  // Heading of the line: rotation about the camera y axis (rad, > 0 turns towards +x), |.| <= 0.5.
  double conductor_yaw_rad = 0.30;
  // Climb of the line at the camera: rotation about the camera x axis (rad, > 0 rises), |.| <= 0.5.
  double conductor_pitch_rad = 0.0;
  // Roll of the rig about its optical axis (rad, > 0 turns the image clockwise), |.| <= 0.3: the
  // sway of a robot hanging from the line.
  double conductor_roll_rad = 0.0;
  // Conductor radius (m); ACSR "Drake" is 28.1 mm across.
  double conductor_radius_m = 0.014;
  // Catenary parameter a = H / w (m): horizontal tension over weight per metre; the sag at mid-span
  // is a (cosh(span / 2a) - 1). Smaller = more sag.
  double sag_parameter_m = 400.0;
  // Distance along the line to the next tower, where the conductors end (m), 10..1000.
  double span_ahead_m = 80.0;
  int conductor_strands = 18;            // outer-layer strands of the helical texture, 6..60
  double conductor_lay_length_m = 0.30;  // helix pitch of the outer strands (m)

  // Background.
  bool towers = true;  // lattice towers carrying the line in the distance
  // x offset of the end tower's body from the middle of the conductors (m, world x), |.| <= 20;
  // its crossarm reaches from the body across all conductors. 0 = the body between the
  // conductors, near the line's vanishing point.
  double tower_offset_x_m = 0.0;
  double ground_depth_m = 12.0;  // terrain height below the camera (m)
  double cloud_cover = 0.45;     // 0 = clear sky, 1 = overcast

  // Lighting: sun direction in the left camera frame given by elevation above the horizon and
  // azimuth from the optical axis towards +x.
  double sun_elevation_deg = 40.0;  // 5..90
  double sun_azimuth_deg = -35.0;   // -180..180
  double ambient = 0.35;            // sky ambient relative to the sun (0..1)

  // Also ray cast an ideal RECTIFIED pair (no distortion, exact rectified cameras, same sensor
  // model) into PowerLineScene::rectified_left/right. Costs about as much as the raw pair.
  bool render_rectified_pair = false;

  void Check() const;
};

// Per-pixel class of the ground truth (rectified left image).
enum class SurfaceClass : std::uint8_t {
  kSky = 0,
  kGround = 1,
  kTower = 2,
  kConductor = 3,
  kObstacle = 4,
};

struct RenderedObstacle {
  int id = 0;  // value of its pixels in PowerLineScene::obstacle_mask (1-based, order of the specs)
  ObstacleType type = ObstacleType::kDamper;
  int conductor = 0;
  double requested_distance_m = 0.0;  // ObstacleSpec::distance_m
  // TRUE distance (m): min ground-truth depth over its visible pixels (see the top of the file).
  double distance_m = 0.0;
  double surface_min_depth_m = 0.0;  // min Z_rect over its whole surface, visible or not (analytic)
  cv::Point nearest_pixel;           // rectified left pixel realising distance_m
  cv::Rect box;            // bounding box of its visible pixels in the rectified left image
  int visible_pixels = 0;  // number of rectified left pixels showing it
  // Arc length along its conductor (m, from the point of conductor 0 nearest to the left camera
  // centre, where the robot is) of its centre and of
  // its near end (centre + ObstacleAlongExtent(type)[0]): how far along the line the robot has to
  // travel before it reaches the obstacle.
  double arc_m = 0.0;
  double near_arc_m = 0.0;
  double tilt_deg = 0.0;  // ObstacleSpec::tilt_deg (a damaged damper)
};

struct RenderedDefect {
  int id = 0;  // value of its pixels in PowerLineScene::defect_mask (1-based, order of the specs)
  DefectType type = DefectType::kBirdcage;
  double arc_m = 0.0;  // arc of its centre (m, DefectSpec::arc_m)
  // Its extent along the line (m of arc, same origin): the span of its surface projected on the
  // line's tangent at its centre.
  double arc_begin_m = 0.0, arc_end_m = 0.0;
  // Birdcage: radius increase (m); broken strands: stand-off of the cut ends (m); string: hanging
  // length (m); sheet: side (m); nest: diameter (m).
  double size_m = 0.0;
  // Min ground-truth depth Z_rect over its visible pixels (m; +inf when none is visible).
  double distance_m = 0.0;
  cv::Rect box;            // bounding box of its visible pixels in the rectified left image
  int visible_pixels = 0;  // number of rectified left pixels showing it
};

// A point of a conductor's axis in the rectified left camera frame with its arc length (m, 0 at the
// point of the conductor nearest to the left camera centre).
struct ConductorAxisPoint {
  double arc_m = 0.0;
  cv::Point3d rect;  // X_rect (m)
};

struct PowerLineScene {
  cv::Mat left, right;            // raw (distorted, unrectified) images, CV_8UC3 BGR
  StereoCalibration calibration;  // the true calibration
  // Rectified left ground truth, +inf where nothing is hit (sky): disparity (CV_32FC1, px) and
  // depth Z_rect (CV_32FC1, m).
  cv::Mat disparity;
  cv::Mat depth;
  cv::Mat obstacle_mask;  // rectified left, CV_8UC1: obstacle id (RenderedObstacle::id), 0 = none
  cv::Mat surface_class;  // rectified left, CV_8UC1: SurfaceClass of each pixel
  std::vector<RenderedObstacle> obstacles;  // one per spec, in spec order
  // Rectified left, CV_8UC1: defect id (RenderedDefect::id), 0 = none; all zero without defects.
  cv::Mat defect_mask;
  std::vector<RenderedDefect> defects;      // one per spec, in spec order
  cv::Mat rectified_left, rectified_right;  // only with render_rectified_pair, CV_8UC3 BGR
  // Axis of conductor 0 (the robot's), sampled every 0.05 m of arc from -0.5 m to 20 m.
  std::vector<ConductorAxisPoint> conductor_axis;
};

// Renders the scene. Throws OptionError for invalid options, InputError when an obstacle cannot be
// placed at its distance (not visible in the rectified left image there, or beyond the span).
PowerLineScene RenderPowerLineScene(const PowerLineSceneOptions& options);

// Renders once, captures many times: the constructor places the obstacles, traces the ground truth
// and the scene radiance (the expensive part); Capture() applies the sensor model (exposure, gain,
// vignetting, blur, noise) with a given noise seed, which takes a few milliseconds. Use it for
// repeated measurements with fresh noise on the same scene. Capture(DefaultNoiseSeed()) equals
// RenderPowerLineScene(options) byte for byte. Same exceptions as RenderPowerLineScene.
class PowerLineSceneRenderer {
 public:
  explicit PowerLineSceneRenderer(const PowerLineSceneOptions& options);
  PowerLineScene Capture(std::uint64_t noise_seed) const;
  // options.sensor.noise_seed if set, else derived from options.seed.
  std::uint64_t DefaultNoiseSeed() const;

 private:
  struct Linear;
  PowerLineSceneOptions options_;
  PowerLineScene ground_truth_;     // everything but the images
  std::shared_ptr<Linear> linear_;  // radiance images, shared by copies
};

// Obstacles as JSON: {"distance_definition": "<the definition above>", "obstacles": [{"id", "type",
// "conductor", "requested_distance_m", "distance_m", "surface_min_depth_m", "nearest_pixel": [u,
// v], "box": [x, y, w, h], "visible_pixels"}]}.
nlohmann::json ObstaclesToJson(const std::vector<RenderedObstacle>& obstacles);

// Defects as JSON: {"defects": [{"id", "type", "arc_m", "arc_begin_m", "arc_end_m", "size_m",
// "distance_m" (null when not visible), "box": [x, y, w, h], "visible_pixels"}]}.
nlohmann::json DefectsToJson(const std::vector<RenderedDefect>& defects);

// Writes into `dir` (created if missing; files written atomically):
//   left.png, right.png        raw pair (8-bit BGR)
//   stereo.yml                 true calibration (OpenCV FileStorage)
//   disparity_gt.pfm           rectified left GT disparity (px, +inf = none)
//   depth_gt.pfm               rectified left GT depth Z (m, +inf = none)
//   obstacle_mask.png          rectified left obstacle ids (8-bit, 0 = none)
//   surface_class.png          rectified left SurfaceClass (8-bit)
//   obstacles.json             ObstaclesToJson
//   defects.json               DefectsToJson, only if the scene has defects
//   defect_mask.png            rectified left defect ids (8-bit, 0 = none), only with defects
//   rectified_left.png, rectified_right.png   only if rendered
void WritePowerLineScene(const std::filesystem::path& dir, const PowerLineScene& scene);

// ----------------------------------------------------------------------------------------------------------
// Calibration boards
// ----------------------------------------------------------------------------------------------------------

struct ChessboardOptions {
  int cols = 9;             // inner corners along the board x axis (>= 2)
  int rows = 6;             // inner corners along the board y axis (>= 2)
  double square_m = 0.040;  // square side (m)
  double border_squares =
      1.0;  // white margin around the squares, in squares (>= 0.5 so detectors work)

  void Check() const;
  // Inner corners in the board frame (z = 0, metres), row-major (index r * cols + c) at (c, r) *
  // square_m, as cv::findChessboardCorners orders them. The squares span [-1, cols] x [-1, rows]
  // squares (the square at (-1, -1) is black) and the white border surrounds that.
  std::vector<cv::Point3f> ObjectPoints() const;
};

// Sensor defaults for boards: finer anti-aliasing than the scene (corners are sub-pixel targets).
inline SensorOptions BoardSensorDefaults() {
  SensorOptions sensor;
  sensor.supersampling = 4;
  return sensor;
}

struct CalibrationBoardOptions {
  StereoRigOptions rig;
  SensorOptions sensor = BoardSensorDefaults();
  ChessboardOptions board;
  std::uint64_t seed = 1;
  // Boards fully visible (with the border and margin_px) in both cameras.
  int num_stereo_views = 15;
  // Boards fully visible in one camera only: the other camera misses >= 2 columns of inner corners.
  int num_left_only = 0;
  int num_right_only = 0;
  // Range of the board-centre depth in the left camera (m).
  double min_distance_m = 0.45;
  double max_distance_m = 1.4;
  // Maximum angle between the board normal and the line of sight (deg).
  double max_tilt_deg = 40.0;
  // Every outer board corner lies at least this far inside an image that "sees" the board (px).
  double margin_px = 8.0;

  void Check() const;
};

struct BoardView {
  cv::Mat left, right;            // raw images, CV_8UC3 BGR (background: a textured grey wall)
  cv::Matx33d left_from_board_R;  // true pose: X_left = R * X_board + t
  cv::Vec3d left_from_board_t;    // (m)
  bool board_in_left = true;      // the whole board (with border) lies inside the left image
  bool board_in_right = true;     // ... inside the right image
  // True projections of ChessboardOptions::ObjectPoints() into each raw image (with distortion),
  // same order.
  std::vector<cv::Point2d> corners_left, corners_right;
};

struct CalibrationBoardSet {
  StereoCalibration calibration;  // the true calibration
  ChessboardOptions board;
  std::vector<BoardView> views;  // stereo views first, then left-only, then right-only
};

CalibrationBoardSet RenderCalibrationBoards(const CalibrationBoardOptions& options);

// Writes into `dir`: left_NN.png, right_NN.png (NN = 00, 01, ...), stereo.yml (true calibration)
// and boards.json {"board": {cols, rows, square_m, border_squares}, "views": [{"left", "right",
// "board_in_left", "board_in_right", "left_from_board_R" (row-major 9), "left_from_board_t"}]}.
void WriteCalibrationBoards(const std::filesystem::path& dir, const CalibrationBoardSet& set);

}  // namespace linesight::sim
