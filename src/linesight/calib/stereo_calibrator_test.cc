#include "linesight/calib/stereo_calibrator.h"

#include <filesystem>

#include <gtest/gtest.h>
#include <Eigen/Dense>

#include "linesight/calib/calib_costs.h"
#include "linesight/calib/calibration_report.h"
#include "linesight/calib/simulation.h"
#include "linesight/core/error.h"
#include "linesight/io/image_io.h"

namespace linesight::calib {
namespace {

StereoCalibrationOptions Options(CalibrationMethod method) {
  StereoCalibrationOptions options;
  options.method = method;
  options.distortion.fix_k3 = true;
  return options;
}

TEST(StereoCalibrationOptions, DefaultsAreValidAndBoundariesRejected) {
  EXPECT_NO_THROW(StereoCalibrationOptions().Check());
  StereoCalibrationOptions o;
  o.min_views = 2;
  EXPECT_THROW(o.Check(), OptionError);
  o = {};
  o.recon_point_weight = -1;
  EXPECT_THROW(o.Check(), OptionError);
  o.recon_point_weight = 1.01;
  EXPECT_THROW(o.Check(), OptionError);
  o.recon_point_weight = 0;
  EXPECT_NO_THROW(o.Check());
  o = {};
  o.min_normal_angle_deg = 90;
  EXPECT_THROW(o.Check(), OptionError);
  EXPECT_NO_THROW(CalibrationStudyOptions().Check());
  EXPECT_NO_THROW(BoardPoseOptions().Check());
}

TEST(ParseMethod, NamesRoundTrip) {
  for (auto m :
       {CalibrationMethod::kZhang, CalibrationMethod::kRecon, CalibrationMethod::kOpenCV}) {
    EXPECT_EQ(ParseMethod(MethodName(m)), m);
  }
  EXPECT_THROW(ParseMethod("tsai"), UsageError);
}

TEST(ParseReconNoise, NamesRoundTrip) {
  for (auto m : {ReconNoiseModel::kIid, ReconNoiseModel::kCamera, ReconNoiseModel::kView})
    EXPECT_EQ(ParseReconNoise(ReconNoiseName(m)), m);
  EXPECT_THROW(ParseReconNoise("pixel"), UsageError);
}

// The per-view noise levels: i.i.d. noise leaves every scale near 1 (the shrinkage removes the
// sampling scatter of 54-corner views), a view with 3x the noise in one camera stands out, the
// per-camera model gives one level per camera and kIid exactly 1.
TEST(EstimateReconNoiseScales, FindsANoisyViewAndStaysAtOneForIidNoise) {
  const SimulationRig rig = DefaultSimulationRig();
  std::mt19937_64 rng(11);
  const auto poses = RandomBoardPoses(rig, 12, BoardPoseOptions(), rng);
  StereoObservations obs = SynthesizeObservations(rig, poses, 0.5, rng);
  const StereoCalibrationResult iid = CalibrateStereo(obs, Options(CalibrationMethod::kZhang));
  for (const auto& scales : EstimateReconNoiseScales(obs, iid, ReconNoiseModel::kView)) {
    EXPECT_NEAR(scales[0], 1.0, 0.08);
    EXPECT_NEAR(scales[1], 1.0, 0.08);
  }
  // View 3's right corners get extra noise: σ = sqrt(0.5² + 1.4²) ≈ 1.5 px.
  std::normal_distribution<double> extra(0.0, 1.4);
  for (auto& p : obs.right[3].pixels) p += Eigen::Vector2d(extra(rng), extra(rng));
  const StereoCalibrationResult noisy = CalibrateStereo(obs, Options(CalibrationMethod::kZhang));
  const auto view = EstimateReconNoiseScales(obs, noisy, ReconNoiseModel::kView);
  EXPECT_GT(view[3][1], 2.0);
  EXPECT_LT(view[3][0], 1.3);
  for (size_t v = 0; v < view.size(); ++v) {
    if (v == 3) continue;
    EXPECT_LT(view[v][0], 1.2) << v;
    EXPECT_LT(view[v][1], 1.2) << v;
  }
  const auto camera = EstimateReconNoiseScales(obs, noisy, ReconNoiseModel::kCamera);
  for (const auto& scales : camera) {
    EXPECT_DOUBLE_EQ(scales[0], camera[0][0]);
    EXPECT_DOUBLE_EQ(scales[1], camera[0][1]);
  }
  EXPECT_GT(camera[0][1], camera[0][0]);
  for (const auto& scales : EstimateReconNoiseScales(obs, noisy, ReconNoiseModel::kIid)) {
    EXPECT_EQ(scales[0], 1.0);
    EXPECT_EQ(scales[1], 1.0);
  }
}

// recon with the per-view model down-weights a noisy view: the intrinsics are closer to the truth
// than with i.i.d. weights on this set (the set of the test above). Two full recon calibrations:
// the ASan run skips it (100 s there; recon's view model is exercised under ASan by
// CalibrateStereo.OpenCVSamplePairs).
TEST(ReconViewNoiseModel, DownWeightsANoisyView) {
  const SimulationRig rig = DefaultSimulationRig();
  std::mt19937_64 rng(11);
  const auto poses = RandomBoardPoses(rig, 12, BoardPoseOptions(), rng);
  StereoObservations obs = SynthesizeObservations(rig, poses, 0.5, rng);
  std::normal_distribution<double> extra(0.0, 1.4);
  for (auto& p : obs.right[3].pixels) p += Eigen::Vector2d(extra(rng), extra(rng));
  StereoCalibrationOptions options = Options(CalibrationMethod::kRecon);
  options.recon_noise = ReconNoiseModel::kIid;
  const StereoCalibrationResult recon_iid = CalibrateStereo(obs, options);
  options.recon_noise = ReconNoiseModel::kView;
  const StereoCalibrationResult recon_view = CalibrateStereo(obs, options);
  const auto squared_error = [&](const StereoCalibrationResult& r) {
    double sum = 0;
    for (int i : {kFx, kFy, kCx, kCy}) {
      sum += std::pow(r.left.params[i] - rig.left.params[i], 2) +
             std::pow(r.right.params[i] - rig.right.params[i], 2);
    }
    return sum;
  };
  EXPECT_LT(squared_error(recon_view), squared_error(recon_iid));
}

TEST(AlignPointSets, RecoversRigidMotionWithProperRotation) {
  Pose truth;
  truth.params = {0.2, -0.4, 0.1, 0.3, -0.1, 0.05};
  std::vector<Eigen::Vector3d> a, b;
  for (int i = 0; i < 20; ++i) {
    const Eigen::Vector3d p(std::sin(i), std::cos(3 * i), 0.1 * i);
    a.push_back(p);
    b.push_back(truth.Apply(p));
  }
  const Pose estimate = AlignPointSets(a, b);
  for (int i = 0; i < kPoseSize; ++i) EXPECT_NEAR(estimate.params[i], truth.params[i], 1e-9);
  // A mirrored point set must still give a rotation (det = +1), never a reflection.
  std::vector<Eigen::Vector3d> mirrored;
  for (const auto& p : a) mirrored.emplace_back(-p.x(), p.y(), p.z());
  EXPECT_NEAR(AlignPointSets(a, mirrored).Rotation().determinant(), 1.0, 1e-9);
}

// The recon corner term is the reprojection χ² written through the 3D reconstruction: for small
// pixel errors its squared norm equals |e|² whatever w_p, and its 3D part is the whitened
// reconstruction error (σ²·A·Aᵀ is the covariance of Δ, so E|W·Δ|² = 3·w²·σ²).
TEST(ReconCornerResidual, EqualsTheReprojectionChiSquareToFirstOrder) {
  const SimulationRig rig = DefaultSimulationRig();
  const Eigen::Vector3d board_point(0.12, 0.08, 0);
  const Pose left_from_board = Pose::FromRotationTranslation(
      Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 0.5, 0).normalized()).toRotationMatrix(),
      Eigen::Vector3d(-0.1, 0.05, 0.8));
  const Eigen::Vector3d in_left = left_from_board.Apply(board_point);
  const Eigen::Vector3d in_right = rig.right_from_left.Apply(in_left);
  Eigen::Vector2d left_exact, right_exact;
  ASSERT_TRUE(Project(rig.left.params.data(), in_left.data(), left_exact.data()));
  ASSERT_TRUE(Project(rig.right.params.data(), in_right.data(), right_exact.data()));
  std::mt19937_64 rng(3);
  std::normal_distribution<double> noise(0.0, 0.01);
  for (double weight : {0.0, 0.6, 1.0}) {
    SCOPED_TRACE(weight);
    double reconstruction_sum = 0;
    const int samples = 400;
    for (int s = 0; s < samples; ++s) {
      const Eigen::Vector4d e(noise(rng), noise(rng), noise(rng), noise(rng));
      const Eigen::Vector2d left_observed = left_exact - e.head<2>();
      const Eigen::Vector2d right_observed = right_exact - e.tail<2>();
      const detail::ReconCornerResidual cost(left_observed, right_observed, board_point,
                                             Eigen::Vector2d(0.4, -0.7), weight);
      const BoardBend flat{};
      double residual[7];
      ASSERT_TRUE(cost(rig.left.params.data(), rig.right.params.data(),
                       left_from_board.params.data(), rig.right_from_left.params.data(),
                       flat.data(), residual));
      const Eigen::Map<const Eigen::Matrix<double, 7, 1>> r(residual);
      EXPECT_NEAR(r.squaredNorm(), e.squaredNorm(), 1e-3 * e.squaredNorm());
      if (weight == 0) {
        EXPECT_NEAR((r.head<4>() - e).norm(), 0, 1e-9);
      }
      if (weight == 1) {
        EXPECT_LT(r.head<4>().norm(), e.norm());  // only the epipolar part is left
      }
      reconstruction_sum += r.tail<3>().squaredNorm();
    }
    EXPECT_NEAR(reconstruction_sum / samples, 3 * weight * weight * 1e-4, 0.6 * weight * 1e-4);
  }
}

// With per-camera noise scales the corner term is the χ² of the pixel residuals in units of each
// camera's noise: |r|² = |e_left|²/s_l² + |e_right|²/s_r² to first order.
TEST(ReconCornerResidual, WhitensEachCameraByItsNoiseScale) {
  const SimulationRig rig = DefaultSimulationRig();
  const Eigen::Vector3d board_point(0.05, 0.1, 0);
  const Pose left_from_board = Pose::FromRotationTranslation(
      Eigen::AngleAxisd(-0.2, Eigen::Vector3d(0.3, 1, 0).normalized()).toRotationMatrix(),
      Eigen::Vector3d(0.05, -0.02, 0.7));
  const Eigen::Vector3d in_left = left_from_board.Apply(board_point);
  const Eigen::Vector3d in_right = rig.right_from_left.Apply(in_left);
  Eigen::Vector2d left_exact, right_exact;
  ASSERT_TRUE(Project(rig.left.params.data(), in_left.data(), left_exact.data()));
  ASSERT_TRUE(Project(rig.right.params.data(), in_right.data(), right_exact.data()));
  std::mt19937_64 rng(4);
  std::normal_distribution<double> noise(0.0, 0.01);
  const double s_left = 2.0, s_right = 0.5;
  for (int s = 0; s < 100; ++s) {
    const Eigen::Vector4d e(noise(rng), noise(rng), noise(rng), noise(rng));
    const detail::ReconCornerResidual cost(left_exact - e.head<2>(), right_exact - e.tail<2>(),
                                           board_point, Eigen::Vector2d(0, 0), 1.0, s_left,
                                           s_right);
    const BoardBend flat{};
    double residual[7];
    ASSERT_TRUE(cost(rig.left.params.data(), rig.right.params.data(), left_from_board.params.data(),
                     rig.right_from_left.params.data(), flat.data(), residual));
    const double expected = e.head<2>().squaredNorm() / (s_left * s_left) +
                            e.tail<2>().squaredNorm() / (s_right * s_right);
    double norm2 = 0;
    for (double r : residual) norm2 += r * r;
    EXPECT_NEAR(norm2, expected, 1e-3 * expected);
  }
}

TEST(CalibrateStereo, RecoversTheRigExactlyWithoutNoise) {
  const SimulationRig rig = DefaultSimulationRig();
  std::mt19937_64 rng(7);
  const auto poses = RandomBoardPoses(rig, 8, BoardPoseOptions(), rng);
  const StereoObservations obs = SynthesizeObservations(rig, poses, 0.0, rng);
  for (auto method :
       {CalibrationMethod::kZhang, CalibrationMethod::kRecon, CalibrationMethod::kOpenCV}) {
    SCOPED_TRACE(MethodName(method));
    const StereoCalibrationResult r = CalibrateStereo(obs, Options(method));
    for (int i : {kFx, kFy, kCx, kCy}) {
      EXPECT_NEAR(r.left.params[i], rig.left.params[i], 1e-3);
      EXPECT_NEAR(r.right.params[i], rig.right.params[i], 1e-3);
    }
    EXPECT_NEAR(r.left.params[kK1], rig.left.params[kK1], 1e-5);
    for (int i = 0; i < kPoseSize; ++i)
      EXPECT_NEAR(r.right_from_left.params[i], rig.right_from_left.params[i], 1e-6);
    EXPECT_LT(StereoRms(obs, r), 1e-4);
  }
}

// recon's board-shape model: corners of a bent board (2 mm sag, 0.5 mm twist over a 320 x 200 mm
// grid) are fitted exactly with the bend estimated, and not by the flat-board model.
TEST(CalibrateStereo, ReconEstimatesTheBendOfABentBoard) {
  SimulationRig rig = DefaultSimulationRig();
  std::mt19937_64 rng(5);
  const auto poses = RandomBoardPoses(rig, 10, BoardPoseOptions(), rng);
  const BoardBend bend = {0.002, -0.001, 0.0005};
  const BoardGeometry flat = rig.board;
  rig.board = BendBoard(flat, bend);
  StereoObservations obs = SynthesizeObservations(rig, poses, 0.0, rng);
  obs.board = flat;  // the calibrator is told the nominal, flat board
  StereoCalibrationOptions options = Options(CalibrationMethod::kRecon);
  options.recon_board_bend = true;
  const StereoCalibrationResult bent = CalibrateStereo(obs, options);
  for (int i = 0; i < kBoardBendSize; ++i) EXPECT_NEAR(bent.board_bend[i], bend[i], 1e-6);
  for (int i : {kFx, kFy, kCx, kCy}) EXPECT_NEAR(bent.left.params[i], rig.left.params[i], 1e-2);
  for (int i = 3; i < kPoseSize; ++i)
    EXPECT_NEAR(bent.right_from_left.params[i], rig.right_from_left.params[i], 1e-5);
  EXPECT_LT(StereoRms(obs, bent), 1e-3);  // evaluated on the bent board
  const StereoCalibrationResult assumed_flat =
      CalibrateStereo(obs, Options(CalibrationMethod::kZhang));
  EXPECT_EQ(assumed_flat.board_bend, BoardBend{});
  EXPECT_GT(StereoRms(obs, assumed_flat), 0.01);
}

TEST(CalibrateStereo, NoisyEstimateIsConsistentWithTheCramerRaoBound) {
  const SimulationRig rig = DefaultSimulationRig();
  std::mt19937_64 rng(11);
  const auto poses = RandomBoardPoses(rig, 10, BoardPoseOptions(), rng);
  const double sigma = 0.5;
  const StereoObservations obs = SynthesizeObservations(rig, poses, sigma, rng);
  const auto bound =
      CramerRaoStddev(rig, poses, sigma, Options(CalibrationMethod::kZhang).distortion);
  for (auto method : {CalibrationMethod::kZhang, CalibrationMethod::kRecon}) {
    SCOPED_TRACE(MethodName(method));
    const StereoCalibrationResult r = CalibrateStereo(obs, Options(method));
    const auto estimate = StudyParameters(r);
    StereoCalibrationResult truth;
    truth.left = rig.left;
    truth.right_from_left = rig.right_from_left;
    const auto expected = StudyParameters(truth);
    for (int i = 0; i < kStudyParameterCount; ++i) {
      EXPECT_GT(bound[i], 0);
      EXPECT_LT(std::abs(estimate[i] - expected[i]), 5 * bound[i]) << kStudyParameterNames[i];
    }
    const CalibrationReport report = EvaluateCalibration(obs, r);
    // Per-point RMS of the 2D error: σ·√2 per point, less the degrees of freedom of the fit.
    EXPECT_NEAR(report.stereo_rms_px, sigma * std::sqrt(2.0), 0.05);
    // The covariance-based standard deviation of fx estimates the bound (same model, σ̂ ≈ σ).
    EXPECT_NEAR(report.left_stddev[kFx], bound[0], 0.3 * bound[0]);
    // |Δy| of two N(0, σ²) coordinates: mean σ·√2·√(2/π) ≈ 0.56 px.
    EXPECT_NEAR(report.epipolar_mean_abs_dy_px, sigma * std::sqrt(2.0) * std::sqrt(2.0 / M_PI),
                0.06);
    EXPECT_GT(report.reconstruction_percent, 1.0);  // noise of depth from 0.5 px at ~0.8 m
    EXPECT_LT(report.reconstruction_percent, 12.0);
  }
}

// Views where only one camera saw the board still serve that camera's intrinsics.
TEST(CalibrateStereo, UsesSingleCameraViews) {
  const SimulationRig rig = DefaultSimulationRig();
  std::mt19937_64 rng(9);
  const auto poses = RandomBoardPoses(rig, 8, BoardPoseOptions(), rng);
  StereoObservations obs = SynthesizeObservations(rig, poses, 0.0, rng);
  obs.right[0] = {};
  obs.right[1] = {};
  obs.left[2] = {};
  for (auto method :
       {CalibrationMethod::kZhang, CalibrationMethod::kRecon, CalibrationMethod::kOpenCV}) {
    SCOPED_TRACE(MethodName(method));
    const StereoCalibrationResult r = CalibrateStereo(obs, Options(method));
    EXPECT_TRUE(r.left_from_board[0].has_value());
    EXPECT_FALSE(r.left_from_board[2].has_value());
    EXPECT_TRUE(r.right_only_from_board[2].has_value());
    EXPECT_NEAR(r.right.fx(), rig.right.fx(), 1e-3);
    EXPECT_NEAR(r.left.cx(), rig.left.cx(), 1e-3);
    const CalibrationReport report = EvaluateCalibration(obs, r);
    EXPECT_TRUE(std::isnan(report.right_view_rms_px[0]));
    EXPECT_TRUE(std::isnan(report.left_view_rms_px[2]));
    EXPECT_LT(report.right_view_rms_px[2], 1e-4);
  }
}

TEST(CalibrateStereo, RejectsBadInput) {
  const SimulationRig rig = DefaultSimulationRig();
  std::mt19937_64 rng(5);
  const auto poses = RandomBoardPoses(rig, 6, BoardPoseOptions(), rng);
  StereoObservations obs = SynthesizeObservations(rig, poses, 0.1, rng);
  // Too few views.
  StereoObservations few = obs;
  few.left.resize(2);
  few.right.resize(2);
  EXPECT_THROW(CalibrateStereo(few, Options(CalibrationMethod::kZhang)), InputError);
  // No board anywhere.
  StereoObservations none = obs;
  for (auto& v : none.left) v = {};
  for (auto& v : none.right) v = {};
  try {
    CalibrateStereo(none, Options(CalibrationMethod::kOpenCV));
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no calibration board"), std::string::npos) << e.what();
  }
  // All boards parallel (translated only): degenerate for every method.
  std::vector<Pose> parallel;
  for (int i = 0; i < 6; ++i) {
    Pose p = poses[0];
    p.params[3] += 0.01 * (i % 3) - 0.01;
    p.params[4] += 0.01 * (i / 3) - 0.005;
    p.params[5] += 0.02 * i;
    parallel.push_back(p);
  }
  const StereoObservations flat = SynthesizeObservations(rig, parallel, 0.1, rng);
  for (auto method :
       {CalibrationMethod::kZhang, CalibrationMethod::kRecon, CalibrationMethod::kOpenCV}) {
    try {
      CalibrateStereo(flat, Options(method));
      FAIL() << "expected InputError";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("degenerate"), std::string::npos) << e.what();
    }
  }
}

// The real data set: opencv-doc's 13 chessboard pairs, 9x6 inner corners, unit squares.
TEST(CalibrateStereo, OpenCVSamplePairs) {
  const std::filesystem::path dir = LINESIGHT_OPENCV_DATA_DIR;
  if (!std::filesystem::exists(dir / "left01.jpg"))
    GTEST_SKIP() << "opencv-doc sample data not installed: " << dir;
  const PatternSpec spec = ParsePatternSpec("chessboard:9x6:1");
  const StereoDetections detections = DetectStereoPairs(
      ExpandGlob((dir / "left[0-9]*.jpg").string()), ExpandGlob((dir / "right[0-9]*.jpg").string()),
      spec, DetectionOptions(), false);
  ASSERT_EQ(detections.pairs.size(), 13u);
  EXPECT_GE(detections.BothCount(), 10);
  const StereoObservations obs = ObservationsFromDetections(detections, MakeBoardGeometry(spec));
  {
    std::vector<Eigen::Matrix3d> homographies;
    for (const auto& v : obs.left) {
      if (v.empty()) continue;
      std::vector<Eigen::Vector2d> xy;
      for (int id : v.ids) xy.push_back(obs.board.points[id].head<2>());
      homographies.push_back(EstimateHomography(xy, v.pixels));
    }
    const double conditioning =
        IntrinsicsFromHomographies(homographies, obs.image_size, "left").conditioning;
    std::printf("closed-form conditioning of the left views: %.4f\n", conditioning);
    EXPECT_GT(conditioning, 0.01);
  }
  std::map<CalibrationMethod, CalibrationReport> reports;
  for (auto method :
       {CalibrationMethod::kOpenCV, CalibrationMethod::kZhang, CalibrationMethod::kRecon}) {
    StereoCalibrationOptions options;
    options.method = method;
    const StereoCalibrationResult r = CalibrateStereo(obs, options);
    reports[method] = EvaluateCalibration(obs, r);
    if (method == CalibrationMethod::kOpenCV) {
      EXPECT_NEAR(reports[method].stereo_rms_px, r.method_reported_rms,
                  0.02 * r.method_reported_rms);
    }
  }
  const double reference = reports[CalibrationMethod::kOpenCV].stereo_rms_px;
  EXPECT_LT(reports[CalibrationMethod::kZhang].stereo_rms_px, 1.05 * reference);
  EXPECT_LT(reports[CalibrationMethod::kRecon].stereo_rms_px, 1.05 * reference);
  // recon's objective equals the reprojection χ² to first order (see stereo_calibrator.h), so its
  // reconstruction error ties with the maximum-likelihood methods instead of beating them: 0.8133 %
  // vs OpenCV's 0.8131 % of the square here (lower is not reachable without giving up
  // efficiency, see docs/algorithms/calibration.md).
  EXPECT_NEAR(reports[CalibrationMethod::kRecon].reconstruction_percent,
              reports[CalibrationMethod::kOpenCV].reconstruction_percent,
              0.01 * reports[CalibrationMethod::kOpenCV].reconstruction_percent);
  for (const auto& [method, report] : reports) {
    std::printf("%-7s stereo RMS %.4f px  epipolar %.4f px  reconstruction %.3f %%\n",
                MethodName(method).c_str(), report.stereo_rms_px, report.epipolar_mean_abs_dy_px,
                report.reconstruction_percent);
  }
}

}  // namespace
}  // namespace linesight::calib
