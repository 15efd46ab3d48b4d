// Calibration boards in random poses, rendered with the same camera models and sensor as the scene.
#include <algorithm>
#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "linesight/core/error.h"
#include "linesight/io/image_io.h"
#include "linesight/io/json_io.h"
#include "linesight/sim/camera_model.h"
#include "linesight/sim/power_line_scene.h"
#include "linesight/sim/procedural_texture.h"
#include "linesight/sim/scene_render.h"
#include "linesight/sim/sensor_model.h"
#include "linesight/sim/sim_internal.h"

namespace linesight::sim {

using detail::Mat3;
using detail::Vec3;

void ChessboardOptions::Check() const {
  CheckOption(cols >= 2 && cols <= 40, "ChessboardOptions.cols", cols, "must be in [2, 40]");
  CheckOption(rows >= 2 && rows <= 40, "ChessboardOptions.rows", rows, "must be in [2, 40]");
  CheckOption(square_m >= 0.002 && square_m <= 1.0, "ChessboardOptions.square_m", square_m,
              "must be in [0.002, 1] m");
  CheckOption(border_squares >= 0.5 && border_squares <= 5, "ChessboardOptions.border_squares",
              border_squares, "must be in [0.5, 5] squares (detectors need a white margin)");
}

std::vector<cv::Point3f> ChessboardOptions::ObjectPoints() const {
  std::vector<cv::Point3f> points;
  points.reserve(static_cast<size_t>(cols) * rows);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      points.emplace_back(static_cast<float>(c * square_m), static_cast<float>(r * square_m), 0.0f);
    }
  }
  return points;
}

void CalibrationBoardOptions::Check() const {
  rig.Check();
  sensor.Check();
  board.Check();
  CheckOption(num_stereo_views >= 0 && num_stereo_views <= 500,
              "CalibrationBoardOptions.num_stereo_views", num_stereo_views, "must be in [0, 500]");
  CheckOption(num_left_only >= 0 && num_left_only <= 500, "CalibrationBoardOptions.num_left_only",
              num_left_only, "must be in [0, 500]");
  CheckOption(num_right_only >= 0 && num_right_only <= 500,
              "CalibrationBoardOptions.num_right_only", num_right_only, "must be in [0, 500]");
  CheckOption(num_stereo_views + num_left_only + num_right_only >= 1,
              "CalibrationBoardOptions.num_stereo_views", num_stereo_views,
              "at least one view must be requested");
  CheckOption(min_distance_m >= 0.1 && min_distance_m <= 20,
              "CalibrationBoardOptions.min_distance_m", min_distance_m, "must be in [0.1, 20] m");
  CheckOption(max_distance_m >= min_distance_m && max_distance_m <= 20,
              "CalibrationBoardOptions.max_distance_m", max_distance_m,
              "must be in [min_distance_m, 20] m");
  CheckOption(max_tilt_deg >= 0 && max_tilt_deg <= 70, "CalibrationBoardOptions.max_tilt_deg",
              max_tilt_deg, "must be in [0, 70] deg");
  CheckOption(margin_px >= 0 && margin_px <= 100, "CalibrationBoardOptions.margin_px", margin_px,
              "must be in [0, 100] px");
}

namespace {

enum class ViewKind { kStereo, kLeftOnly, kRightOnly };

// The board's outline (with border) and inner corners in the board frame.
struct BoardLayout {
  Vec3 centre;  // centre of the board rectangle in the board frame
  double half_u = 0, half_v = 0;
  std::vector<Vec3> outline;  // 4 outer corners
  std::vector<Vec3> inner;    // inner corners (what a detector must find)
};

BoardLayout MakeLayout(const ChessboardOptions& b) {
  BoardLayout layout;
  layout.centre = {0.5 * (b.cols - 1) * b.square_m, 0.5 * (b.rows - 1) * b.square_m, 0};
  layout.half_u = (0.5 * (b.cols + 1) + b.border_squares) * b.square_m;
  layout.half_v = (0.5 * (b.rows + 1) + b.border_squares) * b.square_m;
  for (double su : {-1.0, 1.0}) {
    for (double sv : {-1.0, 1.0}) {
      layout.outline.push_back(layout.centre + Vec3{su * layout.half_u, sv * layout.half_v, 0});
    }
  }
  for (const cv::Point3f& p : b.ObjectPoints()) layout.inner.push_back({p.x, p.y, p.z});
  return layout;
}

struct Pose {
  Mat3 rotation;  // columns: board axes in the left frame
  Vec3 translation;
  Vec3 Apply(Vec3 p) const { return rotation.Apply(p) + translation; }
};

Mat3 AxisAngle(Vec3 axis, double angle) {
  const Vec3 k = detail::Normalized(axis);
  const double c = std::cos(angle), s = std::sin(angle), t = 1 - c;
  return {{t * k.x * k.x + c, t * k.x * k.y - s * k.z, t * k.x * k.z + s * k.y},
          {t * k.x * k.y + s * k.z, t * k.y * k.y + c, t * k.y * k.z - s * k.x},
          {t * k.x * k.z - s * k.y, t * k.y * k.z + s * k.x, t * k.z * k.z + c}};
}

int CountOutside(const CameraIntrinsics& k, const detail::PosedCamera& camera, const Pose& pose,
                 const std::vector<Vec3>& points, cv::Size size, double margin) {
  int outside = 0;
  for (const Vec3& p : points) {
    const Vec3 c = camera.camera_from_scene.Apply(pose.Apply(p)) + camera.translation;
    double u = 0.0, v = 0.0;
    if (c.z < 0.05 || !detail::ProjectPoint(k, c, &u, &v) || u < margin || v < margin ||
        u > size.width - 1 - margin || v > size.height - 1 - margin) {
      ++outside;
    }
  }
  return outside;
}

bool AllInside(const CameraIntrinsics& k, const detail::PosedCamera& camera, const Pose& pose,
               const std::vector<Vec3>& points, cv::Size size, double margin) {
  return CountOutside(k, camera, pose, points, size, margin) == 0;
}

Pose SamplePose(const CalibrationBoardOptions& o, const BoardLayout& layout, ViewKind kind,
                detail::NoiseStream* rng, const detail::RigPoses& poses) {
  const cv::Size size = o.rig.image_size;
  for (int attempt = 0; attempt < 20000; ++attempt) {
    const double depth = o.min_distance_m + (o.max_distance_m - o.min_distance_m) * rng->Uniform();
    double u = size.width * rng->Uniform();
    const double v = size.height * (0.1 + 0.8 * rng->Uniform());
    // One-camera views: the board sits near the outer edge of that camera's image.
    if (kind == ViewKind::kLeftOnly) u = size.width * 0.35 * rng->Uniform();
    if (kind == ViewKind::kRightOnly) u = size.width * (1.0 - 0.35 * rng->Uniform());
    const CameraIntrinsics& k = kind == ViewKind::kRightOnly ? o.rig.right : o.rig.left;
    const detail::PosedCamera& seeing = kind == ViewKind::kRightOnly ? poses.right : poses.left;
    const Vec3 ray = seeing.RayThrough(detail::PixelRay(k, u, v)).direction;
    const Vec3 centre = seeing.centre + (depth / Dot(ray, seeing.camera_from_scene.r2)) * ray;
    // Frame facing the camera along the line of sight, then tilted and turned in plane.
    const Vec3 z0 = detail::Normalized(centre - seeing.centre);
    const Vec3 x_hint = seeing.camera_from_scene.r0;
    const Vec3 x0 = detail::Normalized(x_hint - Dot(x_hint, z0) * z0);
    const Vec3 y0 = Cross(z0, x0);
    const double tilt = o.max_tilt_deg * std::numbers::pi / 180.0 * std::sqrt(rng->Uniform());
    const double tilt_direction = 2.0 * std::numbers::pi * rng->Uniform();
    const double spin = (rng->Uniform() - 0.5) * 0.8;
    const Mat3 facing = Mat3::FromColumns(x0, y0, z0);
    const Mat3 tilt_rotation =
        AxisAngle(std::cos(tilt_direction) * x0 + std::sin(tilt_direction) * y0, tilt);
    const Mat3 rotation =
        detail::Multiply(tilt_rotation, detail::Multiply(facing, AxisAngle({0, 0, 1}, spin)));
    Pose pose{rotation, {0, 0, 0}};
    pose.translation = centre - rotation.Apply(layout.centre);
    const bool in_left = AllInside(o.rig.left, poses.left, pose, layout.outline, size, o.margin_px);
    const bool in_right =
        AllInside(o.rig.right, poses.right, pose, layout.outline, size, o.margin_px);
    if (kind == ViewKind::kStereo && in_left && in_right) return pose;
    // One-camera views: the other camera misses at least two columns of inner corners, so it
    // cannot detect the board.
    const int columns_missing = 2 * o.board.rows;
    if (kind == ViewKind::kLeftOnly && in_left &&
        CountOutside(o.rig.right, poses.right, pose, layout.inner, size, 0.0) >= columns_missing) {
      return pose;
    }
    if (kind == ViewKind::kRightOnly && in_right &&
        CountOutside(o.rig.left, poses.left, pose, layout.inner, size, 0.0) >= columns_missing) {
      return pose;
    }
  }
  throw InputError(
      "cannot find board poses visible as requested: the board is too large for the distance range "
      "(CalibrationBoardOptions.min_distance_m/max_distance_m) or the margin too wide");
}

}  // namespace

CalibrationBoardSet RenderCalibrationBoards(const CalibrationBoardOptions& options) {
  options.Check();
  CalibrationBoardSet set;
  set.calibration = MakeStereoCalibration(options.rig);
  set.board = options.board;
  const cv::Size size = options.rig.image_size;
  const detail::RigPoses poses = detail::MakeRigPoses(set.calibration, Mat3{});
  const BoardLayout layout = MakeLayout(options.board);
  const std::vector<cv::Point3f> object_points = options.board.ObjectPoints();
  detail::NoiseStream rng(detail::Mix64(options.seed ^ 0x0b0a4dULL));
  const std::uint64_t noise_seed =
      options.sensor.noise_seed.value_or(detail::Mix64(options.seed ^ 0x5eed5eedULL));

  std::vector<ViewKind> kinds(options.num_stereo_views, ViewKind::kStereo);
  kinds.insert(kinds.end(), options.num_left_only, ViewKind::kLeftOnly);
  kinds.insert(kinds.end(), options.num_right_only, ViewKind::kRightOnly);
  for (size_t view_index = 0; view_index < kinds.size(); ++view_index) {
    const Pose pose = SamplePose(options, layout, kinds[view_index], &rng, poses);
    detail::RenderScene scene;
    detail::Shape board = detail::MakeRectangle(
        pose.Apply(layout.centre), Vec3{pose.rotation.r0.x, pose.rotation.r1.x, pose.rotation.r2.x},
        Vec3{pose.rotation.r0.y, pose.rotation.r1.y, pose.rotation.r2.y}, layout.half_u,
        layout.half_v);
    board.material = detail::Material::kChessboard;
    board.texture_seed = static_cast<double>(view_index);
    scene.geometry.Add(board);
    // A textured wall behind the board, facing the cameras.
    detail::Shape wall = detail::MakeRectangle({0, 0, options.max_distance_m + 1.5}, {1, 0, 0},
                                               {0, 1, 0}, 50.0, 50.0);
    wall.material = detail::Material::kWall;
    scene.geometry.Add(wall);
    scene.geometry.Build();
    scene.environment.sky = false;
    scene.environment.backdrop = {0.3, 0.3, 0.3};
    scene.environment.up = {0, -1, 0};
    scene.environment.to_sun = detail::Normalized({0.25, -0.45, -1.0});  // from behind the rig
    scene.environment.ambient = 0.45;
    scene.environment.seed = detail::Mix64(options.seed + 17);
    scene.environment.board_cols = options.board.cols;
    scene.environment.board_rows = options.board.rows;
    scene.environment.board_square_m = options.board.square_m;

    BoardView view;
    view.left_from_board_R =
        cv::Matx33d(pose.rotation.r0.x, pose.rotation.r0.y, pose.rotation.r0.z, pose.rotation.r1.x,
                    pose.rotation.r1.y, pose.rotation.r1.z, pose.rotation.r2.x, pose.rotation.r2.y,
                    pose.rotation.r2.z);
    view.left_from_board_t = {pose.translation.x, pose.translation.y, pose.translation.z};
    view.board_in_left = AllInside(options.rig.left, poses.left, pose, layout.outline, size, 0.0);
    view.board_in_right =
        AllInside(options.rig.right, poses.right, pose, layout.outline, size, 0.0);
    for (const cv::Point3f& p : object_points) {
      const Vec3 world = pose.Apply({p.x, p.y, p.z});
      double u = 0.0, v = 0.0;
      detail::ProjectPoint(options.rig.left,
                           poses.left.camera_from_scene.Apply(world) + poses.left.translation, &u,
                           &v);
      view.corners_left.emplace_back(u, v);
      detail::ProjectPoint(options.rig.right,
                           poses.right.camera_from_scene.Apply(world) + poses.right.translation, &u,
                           &v);
      view.corners_right.emplace_back(u, v);
    }
    const SensorOptions& sensor = options.sensor;
    const cv::Mat left_linear =
        detail::RenderLinearImage(scene, options.rig.left, poses.left, size, sensor.supersampling);
    const cv::Mat right_linear = detail::RenderLinearImage(scene, options.rig.right, poses.right,
                                                           size, sensor.supersampling);
    view.left = detail::EncodeSensorImage(left_linear, sensor, 1.0, options.rig.left.cx,
                                          options.rig.left.cy,
                                          detail::Mix64(noise_seed + 2 * view_index + 1));
    view.right = detail::EncodeSensorImage(right_linear, sensor, sensor.right_gain,
                                           options.rig.right.cx, options.rig.right.cy,
                                           detail::Mix64(noise_seed + 2 * view_index + 2));
    set.views.push_back(std::move(view));
  }
  return set;
}

void WriteCalibrationBoards(const std::filesystem::path& dir, const CalibrationBoardSet& set) {
  detail::CreateOutputDirectory(dir);
  nlohmann::json views = nlohmann::json::array();
  for (size_t i = 0; i < set.views.size(); ++i) {
    const BoardView& view = set.views[i];
    const std::string left = fmt::format("left_{:02d}.png", i);
    const std::string right = fmt::format("right_{:02d}.png", i);
    WriteImage(dir / left, view.left);
    WriteImage(dir / right, view.right);
    std::vector<double> rotation(view.left_from_board_R.val, view.left_from_board_R.val + 9);
    views.push_back(
        {{"left", left},
         {"right", right},
         {"board_in_left", view.board_in_left},
         {"board_in_right", view.board_in_right},
         {"left_from_board_R", rotation},
         {"left_from_board_t",
          {view.left_from_board_t[0], view.left_from_board_t[1], view.left_from_board_t[2]}}});
  }
  WriteStereoCalibration(dir / "stereo.yml", set.calibration);
  WriteJson(dir / "boards.json", {{"board",
                                   {{"cols", set.board.cols},
                                    {"rows", set.board.rows},
                                    {"square_m", set.board.square_m},
                                    {"border_squares", set.board.border_squares}}},
                                  {"views", views}});
}

}  // namespace linesight::sim
