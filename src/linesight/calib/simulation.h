// The calibration simulation study: a virtual stereo rig with known parameters, random
// board poses, Gaussian corner noise; every method calibrates the same trials and is compared with
// the truth and with the Cramér-Rao lower bound σ²·(JᵀJ)⁻¹ of the reprojection model at the true
// values.
#pragma once

#include <functional>
#include <random>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "linesight/calib/stereo_calibrator.h"

namespace linesight::calib {

// Virtual rig: 800x600, principal point (400, 300), zero skew, f = 2.1 mm / 3 µm = 700 px, baseline
// 120 mm along −x of the right camera (T = (−0.12, 0.0005, −0.001) m, R a 0.5° rotation), small
// distortion (k1 = −0.05, k2 = 0.02, p1 = 3e-4, p2 = −2e-4, k3 = 0); chessboard 9x6 inner corners,
// 40 mm squares.
struct SimulationRig {
  cv::Size image_size;
  CameraIntrinsics left, right;
  Pose right_from_left;
  BoardGeometry board;
};
SimulationRig DefaultSimulationRig();

struct BoardPoseOptions {
  double min_distance_m = 0.5;  // distance of the board centre from the left camera (m)
  double max_distance_m = 1.1;
  double max_tilt_deg = 40;  // angle between the board normal and the optical axis (deg)
  double max_roll_deg = 20;  // in-plane rotation (deg)
  double margin_px = 10;     // every corner this far inside both images (px)

  void Check() const;
};

// `count` left_from_board poses that keep the whole board inside both images.
std::vector<Pose> RandomBoardPoses(const SimulationRig& rig, int count,
                                   const BoardPoseOptions& options, std::mt19937_64& rng);

// Projects every board point into both cameras and adds N(0, noise_px²) to each coordinate.
StereoObservations SynthesizeObservations(const SimulationRig& rig,
                                          const std::vector<Pose>& left_from_board, double noise_px,
                                          std::mt19937_64& rng);

// Parameters compared in the study.
inline constexpr int kStudyParameterCount = 7;
inline constexpr const char* kStudyParameterNames[kStudyParameterCount] = {"fx", "fy", "u0", "v0",
                                                                           "tx", "ty", "tz"};
// fx fy u0 v0 of the left camera (px) and T of right_from_left (mm).
std::array<double, kStudyParameterCount> StudyParameters(const StereoCalibrationResult& estimate);
// Cramér-Rao standard deviations (same units) for corner noise σ at the true values.
std::array<double, kStudyParameterCount> CramerRaoStddev(const SimulationRig& rig,
                                                         const std::vector<Pose>& left_from_board,
                                                         double noise_px,
                                                         const DistortionModel& model);

struct CalibrationStudyOptions {
  std::vector<double> noise_levels_px = {0,   0.2, 0.4,
                                         0.6, 0.8, 1.0};           // sweep (a), at `images` images
  std::vector<int> image_counts = {6, 8, 10, 12, 14, 16, 18, 20};  // sweep (b), at `noise_px`
  int images = 20;                                                 // image count of sweep (a)
  double noise_px = 0.5;                                           // noise of sweep (b) (px)
  int trials = 20;                                                 // independent trials per point
  std::vector<CalibrationMethod> methods = {CalibrationMethod::kZhang, CalibrationMethod::kRecon,
                                            CalibrationMethod::kOpenCV};
  DistortionModel distortion{.rational = false, .fix_k3 = true, .zero_tangential = false};
  uint64_t seed =
      42;  // trial t of a point uses seed + hash(point, t), so methods see identical data
  BoardPoseOptions poses;
  StereoCalibrationOptions calibration;  // method and distortion are overridden per run

  void Check() const;
};

struct StudyRow {
  std::string sweep;  // "noise" or "images"
  double noise_px = 0;
  int images = 0;
  std::string method;  // or "crlb"
  int trials = 0;      // successful trials
  int failures = 0;
  std::array<double, kStudyParameterCount> mean_abs_error{},
      rms_error{};                 // for "crlb": the bound (RMS σ)
  double reprojection_rms_px = 0;  // mean over trials
};

// Runs both sweeps. `progress(done, total)` is called after every trial.
std::vector<StudyRow> RunCalibrationStudy(const CalibrationStudyOptions& options,
                                          const std::function<void(int, int)>& progress = {});

std::string StudyCsv(const std::vector<StudyRow>& rows);
nlohmann::json StudyJson(const CalibrationStudyOptions& options, const std::vector<StudyRow>& rows);
// One SVG per sweep: a panel per parameter (and reprojection RMS), a line per method plus the
// bound.
std::string StudySvg(const std::vector<StudyRow>& rows, const std::string& sweep, bool rms);

}  // namespace linesight::calib
