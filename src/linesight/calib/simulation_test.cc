#include "linesight/calib/simulation.h"

#include <gtest/gtest.h>

#include "linesight/calib/calibration_report.h"

namespace linesight::calib {
namespace {

TEST(Simulation, DefaultRigMatchesTheIssue) {
  const SimulationRig rig = DefaultSimulationRig();
  EXPECT_EQ(rig.image_size, cv::Size(800, 600));
  EXPECT_DOUBLE_EQ(rig.left.fx(), 700);  // 2.1 mm / 3 µm
  EXPECT_DOUBLE_EQ(rig.left.cx(), 400);
  EXPECT_DOUBLE_EQ(rig.left.cy(), 300);
  EXPECT_NEAR(rig.right_from_left.Translation().norm(), 0.120, 0.0015);
}

TEST(Simulation, PosesKeepTheBoardInsideBothImages) {
  const SimulationRig rig = DefaultSimulationRig();
  std::mt19937_64 rng(1);
  const auto poses = RandomBoardPoses(rig, 10, BoardPoseOptions(), rng);
  const StereoObservations obs = SynthesizeObservations(rig, poses, 0.0, rng);
  for (size_t v = 0; v < obs.size(); ++v) {
    ASSERT_TRUE(obs.IsPair(v));
    for (const auto* view : {&obs.left[v], &obs.right[v]}) {
      for (const Eigen::Vector2d& p : view->pixels) {
        EXPECT_GE(p.x(), 10);
        EXPECT_LE(p.x(), 789);
        EXPECT_GE(p.y(), 10);
        EXPECT_LE(p.y(), 589);
      }
    }
  }
}

// The bound scales linearly with σ and shrinks with more images.
TEST(Simulation, CramerRaoBoundScalesWithNoiseAndImages) {
  const SimulationRig rig = DefaultSimulationRig();
  std::mt19937_64 rng(2);
  const auto poses = RandomBoardPoses(rig, 20, BoardPoseOptions(), rng);
  DistortionModel model;
  model.fix_k3 = true;
  const auto at_half = CramerRaoStddev(rig, poses, 0.5, model);
  const auto at_one = CramerRaoStddev(rig, poses, 1.0, model);
  const auto fewer =
      CramerRaoStddev(rig, std::vector<Pose>(poses.begin(), poses.begin() + 6), 0.5, model);
  for (int i = 0; i < kStudyParameterCount; ++i) {
    EXPECT_NEAR(at_one[i], 2 * at_half[i], 1e-9 * at_one[i]);
    EXPECT_GT(fewer[i], at_half[i]) << kStudyParameterNames[i];
  }
}

TEST(Simulation, SmallStudyProducesEveryRow) {
  CalibrationStudyOptions options;
  options.trials = 2;
  options.noise_levels_px = {0.5};
  options.image_counts = {6};
  options.methods = {CalibrationMethod::kZhang, CalibrationMethod::kOpenCV};
  const auto rows = RunCalibrationStudy(options);
  ASSERT_EQ(rows.size(), 2u * 3);
  for (const StudyRow& r : rows) {
    EXPECT_EQ(r.failures, 0);
    for (int i = 0; i < kStudyParameterCount; ++i) {
      EXPECT_GT(r.rms_error[i], 0);
      EXPECT_LT(r.rms_error[i], 30);  // px or mm; the bound is ~2-5 px for 6 images at 0.5 px
    }
  }
  // Zhang's method with the joint LM and OpenCV reach the same minimum of the same objective.
  EXPECT_NEAR(rows[0].rms_error[0], rows[1].rms_error[0], 0.05);
  EXPECT_NE(StudyCsv(rows).find("sweep,noise_px,images,method"), std::string::npos);
  EXPECT_NE(StudySvg(rows, "noise", true).find("<polyline"), std::string::npos);
  EXPECT_EQ(StudyJson(options, rows)["rows"].size(), rows.size());
}

}  // namespace
}  // namespace linesight::calib
