// Cross-check of the C++ metrics against scripts/verify_metrics.py, an independent Python
// implementation with its own loaders: noisy disparity maps with holes are written in the layout of
// `eval stereo --save-disparity DIR` (DIR/<set>/<scene>/<method>.pfm) with a report in the layout
// of `eval stereo --json`, and the script must agree to 0.01 percentage points and reject a
// perturbed report.
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <random>
#include <set>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "linesight/eval/dataset.h"
#include "linesight/eval/eval_test_util.h"
#include "linesight/eval/metrics.h"
#include "linesight/io/json_io.h"
#include "linesight/io/pfm.h"

namespace linesight {
namespace {

namespace fs = std::filesystem;

using test::kOpenCvData;
using test::kSharedData;
const fs::path kScript = fs::path(LINESIGHT_SOURCE_DIR) / "scripts" / "verify_metrics.py";
constexpr const char* kPython = "/usr/bin/python3";

bool HavePythonWithNumpyAndOpenCv() {
  const std::string command = std::string(kPython) + " -c 'import numpy, cv2' >/dev/null 2>&1";
  return std::system(command.c_str()) == 0;
}

// Runs the script; returns its exit status and leaves its output in `log`.
int RunVerifyMetrics(const fs::path& data, const fs::path& disparities, const fs::path& json,
                     std::string& log) {
  const fs::path log_path = json.parent_path() / "verify.log";
  const std::string command = std::string(kPython) + " '" + kScript.string() + "' --data '" +
                              data.string() + "' --disparities '" + disparities.string() +
                              "' --json '" + json.string() + "' >'" + log_path.string() + "' 2>&1";
  const int status = std::system(command.c_str());
  std::ifstream in(log_path);
  std::stringstream buffer;
  buffer << in.rdbuf();
  log = buffer.str();
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// Ground truth + Gaussian noise (sigma 1.5 px), ~15 % holes, some estimates exactly 1 px and 4 px
// off (threshold ties), and values where the ground truth is unknown.
cv::Mat NoisyDisparity(const cv::Mat& gt, uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0.0f, 1.5f);
  std::uniform_real_distribution<float> uniform(0.0f, 1.0f);
  cv::Mat d(gt.size(), CV_32FC1);
  for (int y = 0; y < gt.rows; ++y) {
    for (int x = 0; x < gt.cols; ++x) {
      const float g = gt.at<float>(y, x);
      const float u = uniform(rng);
      float value = std::isfinite(g) ? g + noise(rng) : 20.0f * uniform(rng);
      if (u < 0.15f)
        value = std::numeric_limits<float>::infinity();
      else if (u < 0.20f && std::isfinite(g))
        value = g + 1.0f;
      else if (u < 0.25f && std::isfinite(g))
        value = g - 4.0f;
      d.at<float>(y, x) = value;
    }
  }
  return d;
}

nlohmann::json ReportEntry(const SceneRef& ref, const std::string& method, const cv::Mat& disparity,
                           const StereoScene& scene) {
  nlohmann::json regions;
  for (const auto& [name, metrics] :
       ComputeRegionMetrics(disparity, scene.ground_truth, scene.masks)) {
    regions[name] = metrics.ToJson();
  }
  return {{"set", ref.set}, {"scene", ref.name}, {"method", method}, {"regions", regions}};
}

class VerifyMetricsScript : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!fs::exists(kScript)) GTEST_SKIP() << kScript << " not found";
    if (!HavePythonWithNumpyAndOpenCv()) {
      GTEST_SKIP() << kPython
                   << " with numpy and cv2 not found (scripts/install-deps.sh installs them)";
    }
    // The process id keeps concurrent runs of this test (several build folders, ctest -j) apart.
    dir_ = fs::temp_directory_path() /
           ("linesight_verify_metrics_" +
            std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) + "_" +
            std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    if (!dir_.empty()) fs::remove_all(dir_, ec);
  }

  // Writes disparities and the report for `refs` (two methods each: noisy and, for the first scene,
  // empty).
  nlohmann::json WriteRun(const std::vector<SceneRef>& refs) {
    nlohmann::json scenes = nlohmann::json::array();
    uint32_t seed = 1;
    for (const SceneRef& ref : refs) {
      const StereoScene scene = LoadScene(ref);
      const fs::path folder = dir_ / "disparity" / ref.set / ref.name;
      fs::create_directories(folder);
      const cv::Mat noisy = NoisyDisparity(scene.ground_truth, seed++);
      WritePfm(folder / "noisy.pfm", noisy);
      scenes.push_back(ReportEntry(ref, "noisy", noisy, scene));
      if (scenes.size() == 1) {
        const cv::Mat empty(scene.ground_truth.size(), CV_32FC1,
                            cv::Scalar(std::numeric_limits<float>::infinity()));
        WritePfm(folder / "empty.pfm", empty);
        scenes.push_back(ReportEntry(ref, "empty", empty, scene));
      }
    }
    return {{"scenes", scenes}};
  }

  fs::path dir_;
};

TEST_F(VerifyMetricsScript, AgreesOnOneSceneOfEverySharedSetAndRejectsAPerturbedReport) {
  if (!fs::exists(kSharedData / "middlebury-2001-2003"))
    GTEST_SKIP() << "no benchmark data at " << kSharedData;
  std::vector<SceneRef> refs;
  std::set<std::string> sets;
  for (const SceneRef& ref : FindScenes(kSharedData)) {
    // One scene per set, and tsukuba for its palette ground truth.
    if (sets.insert(ref.set).second || ref.name == "tsukuba") refs.push_back(ref);
  }
  ASSERT_EQ(sets.size(), 6u);
  nlohmann::json report = WriteRun(refs);
  const fs::path json = dir_ / "report.json";
  WriteJson(json, report);
  std::string log;
  EXPECT_EQ(RunVerifyMetrics(kSharedData, dir_ / "disparity", json, log), 0) << log;
  EXPECT_NE(log.find("OK: every metric within 0.01"), std::string::npos) << log;
  std::cout << log;  // the per-metric differences, for the record

  // Within tolerance: still fine.
  report["scenes"][0]["regions"]["all"]["bad_2"] =
      report["scenes"][0]["regions"]["all"]["bad_2"].get<double>() + 0.005;
  WriteJson(json, report);
  EXPECT_EQ(RunVerifyMetrics(kSharedData, dir_ / "disparity", json, log), 0) << log;

  // Beyond tolerance: rejected, naming the metric.
  report["scenes"][0]["regions"]["all"]["bad_2"] =
      report["scenes"][0]["regions"]["all"]["bad_2"].get<double>() + 0.05;
  WriteJson(json, report);
  EXPECT_EQ(RunVerifyMetrics(kSharedData, dir_ / "disparity", json, log), 1) << log;
  EXPECT_NE(log.find("FAIL: bad_2 differ"), std::string::npos) << log;

  // A wrong pixel count is rejected too.
  report = WriteRun({refs[0]});
  report["scenes"][0]["regions"]["nonocc"]["evaluated"] =
      report["scenes"][0]["regions"]["nonocc"]["evaluated"].get<int64_t>() + 1;
  WriteJson(json, report);
  EXPECT_EQ(RunVerifyMetrics(kSharedData, dir_ / "disparity", json, log), 1) << log;
  EXPECT_NE(log.find("evaluated"), std::string::npos) << log;
}

TEST_F(VerifyMetricsScript, AgreesOnTheOpenCvAloePair) {
  if (!fs::exists(kOpenCvData / "aloeGT.png"))
    GTEST_SKIP() << "no opencv-doc data at " << kOpenCvData;
  const nlohmann::json report = WriteRun(FindScenes(kOpenCvData));
  const fs::path json = dir_ / "report.json";
  WriteJson(json, report);
  std::string log;
  EXPECT_EQ(RunVerifyMetrics(kOpenCvData, dir_ / "disparity", json, log), 0) << log;
}

TEST_F(VerifyMetricsScript, MissingDisparityFileIsReported) {
  if (!fs::exists(kSharedData / "middlebury-2001-2003"))
    GTEST_SKIP() << "no benchmark data at " << kSharedData;
  const nlohmann::json report = {{"scenes",
                                  {{{"set", "middlebury-2001-2003"},
                                    {"scene", "venus"},
                                    {"method", "nothing"},
                                    {"regions", nlohmann::json::object()}}}}};
  const fs::path json = dir_ / "report.json";
  WriteJson(json, report);
  std::string log;
  EXPECT_EQ(RunVerifyMetrics(kSharedData, dir_ / "disparity", json, log), 1) << log;
  EXPECT_NE(log.find("venus/nothing.pfm"), std::string::npos) << log;
}

}  // namespace
}  // namespace linesight
