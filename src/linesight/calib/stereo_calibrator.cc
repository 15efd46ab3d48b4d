// Kept whole: zhang, recon and opencv share the solver setup and the refinement steps below.
#include "linesight/calib/stereo_calibrator.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include <ceres/ceres.h>
#include <Eigen/Dense>
#include <opencv2/calib3d.hpp>

#include "linesight/calib/calib_costs.h"
#include "linesight/core/error.h"

namespace linesight::calib {

namespace {

using detail::BentReprojectionResidual;
using detail::BentStereoReprojectionResidual;
using detail::ReconCornerResidual;
using detail::ReconstructionDistanceResidual;
using detail::ReprojectionResidual;
using detail::StereoReprojectionResidual;

ceres::Solver::Options SolverOptions(const StereoCalibrationOptions& options) {
  ceres::Solver::Options solver;
  solver.linear_solver_type = ceres::DENSE_SCHUR;
  solver.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  solver.max_num_iterations = options.max_iterations;
  solver.function_tolerance = options.function_tolerance;
  solver.gradient_tolerance = 1e-14;
  solver.parameter_tolerance = 1e-12;
  solver.num_threads = 1;
  solver.logging_type = ceres::SILENT;
  return solver;
}

void HoldFixedIntrinsics(ceres::Problem* problem, double* intrinsics,
                         const DistortionModel& model) {
  const std::vector<int> fixed = model.FixedIndices();
  if (!fixed.empty())
    problem->SetManifold(intrinsics, new ceres::SubsetManifold(kNumIntrinsics, fixed));
}

int CountViews(const std::vector<ViewObservations>& views) {
  return static_cast<int>(
      std::count_if(views.begin(), views.end(), [](auto& v) { return !v.empty(); }));
}

struct MonoEstimate {
  CameraIntrinsics intrinsics;
  std::vector<std::optional<Pose>> poses;
};

// Closed form + degeneracy checks for one camera; the LM refinement is separate.
MonoEstimate InitializeMono(const BoardGeometry& board, const std::vector<ViewObservations>& views,
                            cv::Size image_size, const std::string& name,
                            const StereoCalibrationOptions& options) {
  std::vector<Eigen::Matrix3d> homographies;
  std::vector<size_t> view_of_homography;
  for (size_t v = 0; v < views.size(); ++v) {
    if (views[v].ids.size() < 4) continue;
    std::vector<Eigen::Vector2d> board_xy;
    for (int id : views[v].ids) board_xy.push_back(board.points[id].head<2>());
    homographies.push_back(EstimateHomography(board_xy, views[v].pixels));
    view_of_homography.push_back(v);
  }
  const ClosedFormIntrinsics closed = IntrinsicsFromHomographies(
      homographies, image_size, name, options.min_closed_form_conditioning);
  MonoEstimate out;
  out.intrinsics.params[kFx] = closed.camera_matrix(0, 0);
  out.intrinsics.params[kFy] = closed.camera_matrix(1, 1);
  out.intrinsics.params[kCx] = closed.camera_matrix(0, 2);
  out.intrinsics.params[kCy] = closed.camera_matrix(1, 2);
  out.poses.assign(views.size(), std::nullopt);
  std::vector<Pose> poses;
  for (size_t h = 0; h < homographies.size(); ++h) {
    const Pose pose = PoseFromHomography(closed.camera_matrix, homographies[h]);
    out.poses[view_of_homography[h]] = pose;
    poses.push_back(pose);
  }
  const double spread = MaxBoardNormalAngleDeg(poses);
  if (spread < options.min_normal_angle_deg) {
    throw InputError(
        fmt::format("{}: degenerate board poses: the normals of all {} boards lie within {:.2f} "
                    "deg of each other "
                    "(need > {} deg); tilt the board differently between images",
                    name, poses.size(), spread, options.min_normal_angle_deg));
  }
  return out;
}

void RefineMono(const BoardGeometry& board, const std::vector<ViewObservations>& views,
                const StereoCalibrationOptions& options, MonoEstimate* estimate) {
  ceres::Problem problem;
  double* intrinsics = estimate->intrinsics.params.data();
  for (size_t v = 0; v < views.size(); ++v) {
    if (!estimate->poses[v]) continue;
    for (size_t k = 0; k < views[v].ids.size(); ++k) {
      problem.AddResidualBlock(
          ReprojectionResidual::Create(views[v].pixels[k], board.points[views[v].ids[k]]), nullptr,
          intrinsics, estimate->poses[v]->params.data());
    }
  }
  HoldFixedIntrinsics(&problem, intrinsics, options.distortion);
  ceres::Solver::Summary summary;
  ceres::Solve(SolverOptions(options), &problem, &summary);
}

Pose MeanRightFromLeft(const std::vector<Pose>& per_view) {
  Eigen::Matrix3d rotation_sum = Eigen::Matrix3d::Zero();
  std::vector<double> tx, ty, tz;
  for (const Pose& p : per_view) {
    rotation_sum += p.Rotation();
    tx.push_back(p.params[3]);
    ty.push_back(p.params[4]);
    tz.push_back(p.params[5]);
  }
  const auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    const size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
  };
  return Pose::FromRotationTranslation(NearestRotation(rotation_sum),
                                       Eigen::Vector3d(median(tx), median(ty), median(tz)));
}

// The joint refinement of zhang and recon (see the header for the objective).
// noise[v] = relative pixel-noise scales (left, right) of view v (empty: all 1): every recon
// residual of that camera is divided by it.
void RefineJoint(const StereoObservations& obs, const StereoCalibrationOptions& options,
                 bool recon_terms, const std::vector<std::array<double, 2>>& noise,
                 StereoCalibrationResult* result) {
  const bool recon_corners = recon_terms && options.recon_point_weight > 0;
  const bool recon_distances = recon_terms && options.recon_distance_weight > 0;
  ceres::Problem problem;
  double* left_intrinsics = result->left.params.data();
  double* right_intrinsics = result->right.params.data();
  double* right_from_left = result->right_from_left.params.data();
  problem.AddParameterBlock(left_intrinsics, kNumIntrinsics);
  problem.AddParameterBlock(right_intrinsics, kNumIntrinsics);
  problem.AddParameterBlock(right_from_left, kPoseSize);
  // recon estimates the board's bend (or holds it at zero); zhang keeps the flat board.
  double* bend = result->board_bend.data();
  if (recon_terms) {
    problem.AddParameterBlock(bend, kBoardBendSize);
    if (!options.recon_board_bend) problem.SetParameterBlockConstant(bend);
  }
  const BoardGeometry& board = obs.board;
  const std::vector<Eigen::Vector2d> uv = BoardBendCoordinates(board);
  const double f0 = result->left.fx();
  // One camera's reprojection term, on the bent board for recon.
  const auto noise_of = [&](size_t v, int camera) {
    return noise.empty() ? 1.0 : noise[v][camera];
  };
  const auto add_reprojection = [&](const Eigen::Vector2d& pixel, int id, double* intrinsics,
                                    double* pose, double scale) {
    if (recon_terms) {
      problem.AddResidualBlock(BentReprojectionResidual::Create(pixel, board.points[id], uv[id]),
                               scale == 1.0 ? nullptr
                                            : new ceres::ScaledLoss(nullptr, 1.0 / (scale * scale),
                                                                    ceres::TAKE_OWNERSHIP),
                               intrinsics, pose, bend);
    } else {
      problem.AddResidualBlock(ReprojectionResidual::Create(pixel, board.points[id]), nullptr,
                               intrinsics, pose);
    }
  };
  for (size_t v = 0; v < obs.size(); ++v) {
    const ViewObservations& left = obs.left[v];
    const ViewObservations& right = obs.right[v];
    // Corners both cameras saw in this view: id -> (left pixel, right pixel).
    std::map<int, std::pair<Eigen::Vector2d, Eigen::Vector2d>> common;
    {
      std::map<int, Eigen::Vector2d> right_by_id;
      for (size_t k = 0; k < right.ids.size(); ++k) right_by_id[right.ids[k]] = right.pixels[k];
      for (size_t k = 0; k < left.ids.size(); ++k) {
        const auto it = right_by_id.find(left.ids[k]);
        if (it != right_by_id.end()) common[left.ids[k]] = {left.pixels[k], it->second};
      }
    }
    if (!left.empty() && result->left_from_board[v]) {
      double* pose = result->left_from_board[v]->params.data();
      // Corners both cameras saw become recon corner terms; the others keep plain reprojection.
      std::set<int> as_recon_corner;
      for (size_t k = 0; k < left.ids.size() && recon_corners; ++k) {
        const auto it = common.find(left.ids[k]);
        if (it == common.end()) continue;
        problem.AddResidualBlock(
            ReconCornerResidual::Create(left.pixels[k], it->second.second,
                                        board.points[left.ids[k]], uv[left.ids[k]],
                                        options.recon_point_weight, noise_of(v, 0), noise_of(v, 1)),
            nullptr, left_intrinsics, right_intrinsics, pose, right_from_left, bend);
        as_recon_corner.insert(left.ids[k]);
      }
      for (size_t k = 0; k < left.ids.size(); ++k) {
        if (as_recon_corner.count(left.ids[k])) continue;
        add_reprojection(left.pixels[k], left.ids[k], left_intrinsics, pose, noise_of(v, 0));
      }
      for (size_t k = 0; k < right.ids.size(); ++k) {
        if (as_recon_corner.count(right.ids[k])) continue;
        const int id = right.ids[k];
        if (recon_terms) {
          const double scale = noise_of(v, 1);
          problem.AddResidualBlock(
              BentStereoReprojectionResidual::Create(right.pixels[k], board.points[id], uv[id]),
              scale == 1.0
                  ? nullptr
                  : new ceres::ScaledLoss(nullptr, 1.0 / (scale * scale), ceres::TAKE_OWNERSHIP),
              right_intrinsics, pose, right_from_left, bend);
        } else {
          problem.AddResidualBlock(
              StereoReprojectionResidual::Create(right.pixels[k], board.points[id]), nullptr,
              right_intrinsics, pose, right_from_left);
        }
      }
    } else if (!right.empty() && result->right_only_from_board[v]) {
      double* pose = result->right_only_from_board[v]->params.data();
      for (size_t k = 0; k < right.ids.size(); ++k)
        add_reprojection(right.pixels[k], right.ids[k], right_intrinsics, pose, noise_of(v, 1));
    }
    if (!recon_distances || !obs.IsPair(v) || !result->left_from_board[v]) continue;
    const Pose& left_from_board = *result->left_from_board[v];
    for (const AdjacentPair& pair : board.adjacent) {
      const auto a = common.find(pair.a);
      const auto b = common.find(pair.b);
      if (a == common.end() || b == common.end()) continue;
      const double depth = std::max(0.5 * (left_from_board.Apply(board.points[pair.a]).z() +
                                           left_from_board.Apply(board.points[pair.b]).z()),
                                    1e-6);
      problem.AddResidualBlock(
          ReconstructionDistanceResidual::Create(a->second.first, a->second.second, b->second.first,
                                                 b->second.second, pair.distance_m,
                                                 options.recon_distance_weight * f0 / depth),
          nullptr, left_intrinsics, right_intrinsics, right_from_left);
    }
  }
  HoldFixedIntrinsics(&problem, left_intrinsics, options.distortion);
  HoldFixedIntrinsics(&problem, right_intrinsics, options.distortion);
  ceres::Solver::Summary summary;
  ceres::Solve(SolverOptions(options), &problem, &summary);
}

// recon's noise-model rounds: estimate the levels from the residuals, refine again.
constexpr int kNoiseRounds = 2;

// Refines one board pose with everything else fixed (used after OpenCV's calibration).
void RefinePoseOnly(const BoardGeometry& board, const ViewObservations* view_a,
                    CameraIntrinsics intrinsics_a, const ViewObservations* view_b,
                    CameraIntrinsics intrinsics_b, Pose b_from_a,
                    const StereoCalibrationOptions& options, Pose* pose) {
  ceres::Problem problem;
  for (size_t k = 0; k < view_a->ids.size(); ++k) {
    problem.AddResidualBlock(
        ReprojectionResidual::Create(view_a->pixels[k], board.points[view_a->ids[k]]), nullptr,
        intrinsics_a.params.data(), pose->params.data());
  }
  if (view_b != nullptr) {
    for (size_t k = 0; k < view_b->ids.size(); ++k) {
      problem.AddResidualBlock(
          StereoReprojectionResidual::Create(view_b->pixels[k], board.points[view_b->ids[k]]),
          nullptr, intrinsics_b.params.data(), pose->params.data(), b_from_a.params.data());
    }
    problem.SetParameterBlockConstant(intrinsics_b.params.data());
    problem.SetParameterBlockConstant(b_from_a.params.data());
  }
  problem.SetParameterBlockConstant(intrinsics_a.params.data());
  ceres::Solver::Options solver = SolverOptions(options);
  solver.linear_solver_type = ceres::DENSE_QR;
  ceres::Solver::Summary summary;
  ceres::Solve(solver, &problem, &summary);
}

std::vector<cv::Point3f> ObjectPoints(const BoardGeometry& board, const std::vector<int>& ids) {
  std::vector<cv::Point3f> out;
  for (int id : ids) {
    const Eigen::Vector3d& p = board.points[id];
    out.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()),
                     static_cast<float>(p.z()));
  }
  return out;
}

std::vector<cv::Point2f> ImagePoints(const std::vector<Eigen::Vector2d>& pixels) {
  std::vector<cv::Point2f> out;
  for (const auto& p : pixels)
    out.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()));
  return out;
}

Pose SolvePnP(const BoardGeometry& board, const ViewObservations& view,
              const CameraIntrinsics& camera, int distortion_count) {
  cv::Mat rvec, tvec;
  cv::solvePnP(ObjectPoints(board, view.ids), ImagePoints(view.pixels), camera.CameraMatrix(),
               camera.Distortion(distortion_count), rvec, tvec);
  return Pose::FromOpenCV(rvec, tvec);
}

void CalibrateOpenCV(const StereoObservations& obs, const StereoCalibrationOptions& options,
                     StereoCalibrationResult* result) {
  const int flags = options.distortion.OpenCVFlags();
  const cv::TermCriteria criteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS,
                                  options.max_iterations, 1e-12);
  const auto mono = [&](const std::vector<ViewObservations>& views) {
    std::vector<std::vector<cv::Point3f>> object;
    std::vector<std::vector<cv::Point2f>> image;
    for (const ViewObservations& v : views) {
      if (v.empty()) continue;
      object.push_back(ObjectPoints(obs.board, v.ids));
      image.push_back(ImagePoints(v.pixels));
    }
    cv::Mat k, d;
    std::vector<cv::Mat> rvecs, tvecs;
    cv::calibrateCamera(object, image, obs.image_size, k, d, rvecs, tvecs, flags, criteria);
    return CameraIntrinsics::FromOpenCV(k, d);
  };
  CameraIntrinsics left = mono(obs.left);
  CameraIntrinsics right = mono(obs.right);
  // Stereo on the corners both cameras saw.
  std::vector<std::vector<cv::Point3f>> object;
  std::vector<std::vector<cv::Point2f>> left_image, right_image;
  for (size_t v = 0; v < obs.size(); ++v) {
    if (!obs.IsPair(v)) continue;
    std::map<int, Eigen::Vector2d> right_by_id;
    for (size_t k = 0; k < obs.right[v].ids.size(); ++k)
      right_by_id[obs.right[v].ids[k]] = obs.right[v].pixels[k];
    std::vector<int> ids;
    std::vector<Eigen::Vector2d> lp, rp;
    for (size_t k = 0; k < obs.left[v].ids.size(); ++k) {
      const auto it = right_by_id.find(obs.left[v].ids[k]);
      if (it == right_by_id.end()) continue;
      ids.push_back(obs.left[v].ids[k]);
      lp.push_back(obs.left[v].pixels[k]);
      rp.push_back(it->second);
    }
    if (ids.size() < 4) continue;
    object.push_back(ObjectPoints(obs.board, ids));
    left_image.push_back(ImagePoints(lp));
    right_image.push_back(ImagePoints(rp));
  }
  const int count = options.distortion.OpenCVCount();
  cv::Mat k1 = left.CameraMatrix(), d1 = left.Distortion(count);
  cv::Mat k2 = right.CameraMatrix(), d2 = right.Distortion(count);
  cv::Mat r, t, e, f;
  result->method_reported_rms =
      cv::stereoCalibrate(object, left_image, right_image, k1, d1, k2, d2, obs.image_size, r, t, e,
                          f, flags | cv::CALIB_USE_INTRINSIC_GUESS, criteria);
  result->left = CameraIntrinsics::FromOpenCV(k1, d1);
  result->right = CameraIntrinsics::FromOpenCV(k2, d2);
  result->right_from_left = Pose::FromOpenCV(r, t);
  for (size_t v = 0; v < obs.size(); ++v) {
    if (!obs.left[v].empty()) {
      Pose pose = SolvePnP(obs.board, obs.left[v], result->left, count);
      RefinePoseOnly(obs.board, &obs.left[v], result->left, obs.IsPair(v) ? &obs.right[v] : nullptr,
                     result->right, result->right_from_left, options, &pose);
      result->left_from_board[v] = pose;
    } else if (!obs.right[v].empty()) {
      Pose pose = SolvePnP(obs.board, obs.right[v], result->right, count);
      RefinePoseOnly(obs.board, &obs.right[v], result->right, nullptr, result->right, Pose(),
                     options, &pose);
      result->right_only_from_board[v] = pose;
    }
  }
}

}  // namespace

std::string MethodName(CalibrationMethod method) {
  switch (method) {
    case CalibrationMethod::kZhang:
      return "zhang";
    case CalibrationMethod::kRecon:
      return "recon";
    case CalibrationMethod::kOpenCV:
      return "opencv";
  }
  return "?";
}

std::string ReconNoiseName(ReconNoiseModel model) {
  switch (model) {
    case ReconNoiseModel::kIid:
      return "iid";
    case ReconNoiseModel::kCamera:
      return "camera";
    case ReconNoiseModel::kView:
      return "view";
  }
  return "?";
}

ReconNoiseModel ParseReconNoise(const std::string& name) {
  if (name == "iid") return ReconNoiseModel::kIid;
  if (name == "camera") return ReconNoiseModel::kCamera;
  if (name == "view") return ReconNoiseModel::kView;
  throw UsageError(
      fmt::format("unknown recon noise model '{}' (expected iid, camera or view)", name));
}

CalibrationMethod ParseMethod(const std::string& name) {
  if (name == "zhang") return CalibrationMethod::kZhang;
  if (name == "recon") return CalibrationMethod::kRecon;
  if (name == "opencv") return CalibrationMethod::kOpenCV;
  throw UsageError(
      fmt::format("unknown calibration method '{}' (expected zhang, recon or opencv)", name));
}

StereoObservations ObservationsFromDetections(const StereoDetections& detections,
                                              const BoardGeometry& board) {
  StereoObservations obs;
  obs.board = board;
  obs.image_size = detections.image_size;
  const auto convert = [](const Detection& d) {
    ViewObservations v;
    if (!d.found) return v;
    v.ids = d.ids;
    for (const cv::Point2d& p : d.pixels) v.pixels.emplace_back(p.x, p.y);
    return v;
  };
  for (const PairDetection& pair : detections.pairs) {
    obs.left.push_back(convert(pair.left));
    obs.right.push_back(convert(pair.right));
  }
  return obs;
}

std::vector<int> DistortionModel::FixedIndices() const {
  std::vector<int> fixed;
  if (zero_tangential) {
    fixed.push_back(kP1);
    fixed.push_back(kP2);
  }
  if (fix_k3) fixed.push_back(kK3);
  if (!rational) {
    fixed.push_back(kK4);
    fixed.push_back(kK5);
    fixed.push_back(kK6);
  }
  return fixed;
}

int DistortionModel::OpenCVFlags() const {
  int flags = 0;
  if (rational) flags |= cv::CALIB_RATIONAL_MODEL;
  if (fix_k3) flags |= cv::CALIB_FIX_K3;
  if (zero_tangential) flags |= cv::CALIB_ZERO_TANGENT_DIST;
  return flags;
}

void StereoCalibrationOptions::Check() const {
  CheckOption(min_views >= 3, "StereoCalibrationOptions.min_views", min_views, "must be >= 3");
  CheckOption(min_normal_angle_deg >= 0 && min_normal_angle_deg < 90,
              "StereoCalibrationOptions.min_normal_angle_deg", min_normal_angle_deg,
              "must be in [0, 90)");
  CheckOption(min_closed_form_conditioning >= 0 && min_closed_form_conditioning < 1,
              "StereoCalibrationOptions.min_closed_form_conditioning", min_closed_form_conditioning,
              "must be in [0, 1)");
  CheckOption(max_iterations >= 1, "StereoCalibrationOptions.max_iterations", max_iterations,
              "must be >= 1");
  CheckOption(function_tolerance > 0 && function_tolerance < 1,
              "StereoCalibrationOptions.function_tolerance", function_tolerance,
              "must be in (0, 1)");
  CheckOption(recon_point_weight >= 0 && recon_point_weight <= 1,
              "StereoCalibrationOptions.recon_point_weight", recon_point_weight,
              "must be in [0, 1]");
  CheckOption(recon_distance_weight >= 0 && std::isfinite(recon_distance_weight),
              "StereoCalibrationOptions.recon_distance_weight", recon_distance_weight,
              "must be finite and >= 0");
}

StereoCalibrationResult CalibrateStereo(const StereoObservations& obs,
                                        const StereoCalibrationOptions& options) {
  options.Check();
  LS_CHECK(obs.left.size() == obs.right.size());
  const int left_views = CountViews(obs.left);
  const int right_views = CountViews(obs.right);
  int pair_views = 0;
  for (size_t v = 0; v < obs.size(); ++v) pair_views += obs.IsPair(v) ? 1 : 0;
  if (left_views == 0 && right_views == 0) {
    throw InputError(
        fmt::format("no calibration board found in any of the {} image pairs", obs.size()));
  }
  if (left_views < options.min_views || right_views < options.min_views ||
      pair_views < options.min_views) {
    throw InputError(
        fmt::format("too few views: the board was found in {} left, {} right and {} pair images; "
                    "need at least {} of each",
                    left_views, right_views, pair_views, options.min_views));
  }
  for (size_t v = 0; v < obs.size(); ++v) {
    for (const auto* views : {&obs.left, &obs.right}) {
      const ViewObservations& view = (*views)[v];
      if (!view.empty() && view.ids.size() < 4) {
        throw InputError(
            fmt::format("view {} has only {} corners (need >= 4)", v, view.ids.size()));
      }
    }
  }
  // Degeneracy checks and the closed form for every method, so that bad input fails the same way.
  MonoEstimate left = InitializeMono(obs.board, obs.left, obs.image_size, "left camera", options);
  MonoEstimate right =
      InitializeMono(obs.board, obs.right, obs.image_size, "right camera", options);

  StereoCalibrationResult result;
  result.method = options.method;
  result.distortion = options.distortion;
  result.left_from_board.assign(obs.size(), std::nullopt);
  result.right_only_from_board.assign(obs.size(), std::nullopt);
  if (options.method == CalibrationMethod::kOpenCV) {
    CalibrateOpenCV(obs, options, &result);
    return result;
  }
  RefineMono(obs.board, obs.left, options, &left);
  RefineMono(obs.board, obs.right, options, &right);
  result.left = left.intrinsics;
  result.right = right.intrinsics;
  if (options.method == CalibrationMethod::kZhang) {
    std::vector<Pose> per_view;
    for (size_t v = 0; v < obs.size(); ++v) {
      if (obs.IsPair(v)) per_view.push_back(*right.poses[v] * left.poses[v]->Inverse());
    }
    result.right_from_left = MeanRightFromLeft(per_view);
  } else {
    std::vector<Eigen::Vector3d> in_left, in_right;
    for (size_t v = 0; v < obs.size(); ++v) {
      if (!obs.IsPair(v)) continue;
      for (const Eigen::Vector3d& p : obs.board.points) {
        in_left.push_back(left.poses[v]->Apply(p));
        in_right.push_back(right.poses[v]->Apply(p));
      }
    }
    result.right_from_left = AlignPointSets(in_left, in_right);
  }
  for (size_t v = 0; v < obs.size(); ++v) {
    if (left.poses[v]) {
      result.left_from_board[v] = left.poses[v];
    } else if (right.poses[v]) {
      result.right_only_from_board[v] = right.poses[v];
    }
  }
  const bool recon = options.method == CalibrationMethod::kRecon;
  RefineJoint(obs, options, recon, {}, &result);
  if (recon && options.recon_noise != ReconNoiseModel::kIid) {
    for (int round = 0; round < kNoiseRounds; ++round) {
      RefineJoint(obs, options, true, EstimateReconNoiseScales(obs, result, options.recon_noise),
                  &result);
    }
  }
  return result;
}

std::vector<std::array<double, 2>> EstimateReconNoiseScales(const StereoObservations& obs,
                                                            const StereoCalibrationResult& est,
                                                            ReconNoiseModel model) {
  const BoardGeometry board = BendBoard(obs.board, est.board_bend);
  std::vector<std::array<double, 2>> sum2(obs.size(), {0.0, 0.0}), dof(obs.size(), {0.0, 0.0});
  for (size_t v = 0; v < obs.size(); ++v) {
    for (int camera = 0; camera < 2; ++camera) {
      const ViewObservations& view = camera == 0 ? obs.left[v] : obs.right[v];
      if (view.empty()) continue;
      std::optional<Pose> pose;
      const CameraIntrinsics& intrinsics = camera == 0 ? est.left : est.right;
      if (est.left_from_board[v]) {
        pose =
            camera == 0 ? *est.left_from_board[v] : est.right_from_left * *est.left_from_board[v];
      } else if (camera == 1) {
        pose = est.right_only_from_board[v];
      }
      if (!pose) continue;
      for (size_t k = 0; k < view.ids.size(); ++k) {
        const Eigen::Vector3d p = pose->Apply(board.points[view.ids[k]]);
        double pixel[2];
        if (!Project(intrinsics.params.data(), p.data(), pixel)) continue;
        sum2[v][camera] += (Eigen::Vector2d(pixel[0], pixel[1]) - view.pixels[k]).squaredNorm();
        dof[v][camera] += 2;
      }
      dof[v][camera] -= obs.IsPair(v) ? 3 : 6;
    }
  }
  // Groups: one per camera (kCamera) or per camera and view (kView); group g of (v, c).
  const auto group_of = [&](size_t v, int c) {
    return model == ReconNoiseModel::kCamera ? static_cast<size_t>(c) : 2 * v + c;
  };
  const size_t group_count = model == ReconNoiseModel::kCamera ? 2 : 2 * obs.size();
  std::vector<double> group_sum(group_count, 0.0), group_dof(group_count, 0.0);
  double pooled_sum = 0, pooled_dof = 0;
  for (size_t v = 0; v < obs.size(); ++v) {
    for (int c = 0; c < 2; ++c) {
      if (dof[v][c] <= 0) continue;
      group_sum[group_of(v, c)] += sum2[v][c];
      group_dof[group_of(v, c)] += dof[v][c];
      pooled_sum += sum2[v][c];
      pooled_dof += dof[v][c];
    }
  }
  std::vector<std::array<double, 2>> scales(obs.size(), {1.0, 1.0});
  if (!(pooled_sum > 0) || model == ReconNoiseModel::kIid) return scales;
  const double pooled = pooled_sum / pooled_dof;
  // Empirical-Bayes shrinkage toward the pooled level: a group's s² scatters around its true
  // variance with variance 2σ⁴/dof (χ²), so only the spread of the s² beyond that, τ², is
  // real heteroscedasticity; each group keeps the share τ² / (τ² + 2·pooled²/dof) of its
  // deviation. With i.i.d. noise τ² ≈ 0 and every scale stays ≈ 1 (no weights from sampling
  // noise alone).
  double spread = 0, sampling = 0;
  int groups = 0;
  for (size_t g = 0; g < group_count; ++g) {
    if (group_dof[g] <= 0) continue;
    const double s2 = group_sum[g] / group_dof[g];
    spread += (s2 - pooled) * (s2 - pooled);
    sampling += 2 * pooled * pooled / group_dof[g];
    ++groups;
  }
  const double tau2 = groups > 1 ? std::max(0.0, (spread - sampling) / groups) : 0.0;
  for (size_t v = 0; v < obs.size(); ++v) {
    for (int c = 0; c < 2; ++c) {
      const size_t g = group_of(v, c);
      if (group_dof[g] <= 0) continue;
      const double s2 = group_sum[g] / group_dof[g];
      const double share = tau2 / (tau2 + 2 * pooled * pooled / group_dof[g]);
      scales[v][c] = std::sqrt((pooled + share * (s2 - pooled)) / pooled);
    }
  }
  return scales;
}

Pose AlignPointSets(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b) {
  LS_CHECK(a.size() == b.size() && a.size() >= 3);
  Eigen::Vector3d mean_a = Eigen::Vector3d::Zero(), mean_b = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < a.size(); ++i) {
    mean_a += a[i];
    mean_b += b[i];
  }
  mean_a /= static_cast<double>(a.size());
  mean_b /= static_cast<double>(b.size());
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // Σ (b − b̄)(a − ā)ᵀ
  for (size_t i = 0; i < a.size(); ++i) covariance += (b[i] - mean_b) * (a[i] - mean_a).transpose();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(covariance, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0)
    d(2, 2) = -1;  // proper rotation
  const Eigen::Matrix3d rotation = svd.matrixU() * d * svd.matrixV().transpose();
  return Pose::FromRotationTranslation(rotation, mean_b - rotation * mean_a);
}

Eigen::Vector3d TriangulateMidpoint(const Eigen::Vector2d& left_normalized,
                                    const Eigen::Vector2d& right_normalized,
                                    const Pose& right_from_left) {
  Eigen::Vector3d point;
  detail::TriangulateMidpointT(left_normalized.data(), right_normalized.data(),
                               right_from_left.params.data(), point.data());
  return point;
}

}  // namespace linesight::calib
