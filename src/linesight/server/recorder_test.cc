#include "linesight/server/recorder.h"

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "linesight/core/error.h"
#include "linesight/io/image_io.h"
#include "linesight/io/stereo_calibration.h"

namespace linesight {
namespace {
namespace fs = std::filesystem;

class RecorderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    parent_ =
        fs::temp_directory_path() /
        ("linesight_recorder_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
         "_" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(parent_);
  }
  void TearDown() override { fs::remove_all(parent_); }
  static StereoCalibration Calibration() {
    return RectifiedPinholeCalibration(cv::Size(64, 48), 50.0, 32.0, 24.0, 0.1);
  }
  fs::path parent_;
};

cv::Mat Frame(int value) {
  return cv::Mat(48, 64, CV_8UC3, cv::Scalar(value, value + 1, value + 2));
}

TEST_F(RecorderTest, WritesPairsCalibrationAndResultLinesThatReplayInOrder) {
  Recorder recorder(64);
  EXPECT_FALSE(recorder.on());
  recorder.Add(Frame(1), Frame(2), {{"frame", -1}});  // not recording: ignored
  const fs::path dir = recorder.Start(parent_, Calibration());
  EXPECT_TRUE(recorder.on());
  for (int i = 0; i < 5; ++i) recorder.Add(Frame(10 * i), Frame(10 * i + 5), {{"frame", i}});
  recorder.Stop();
  EXPECT_FALSE(recorder.on());
  EXPECT_EQ(recorder.Status()["frames"], 5);
  EXPECT_EQ(recorder.Status()["dropped"], 0);
  EXPECT_EQ(recorder.Status()["error"], "");

  const std::vector<fs::path> left = ExpandGlob((dir / "left" / "*.png").string());
  const std::vector<fs::path> right = ExpandGlob((dir / "right" / "*.png").string());
  ASSERT_EQ(left.size(), 5u);
  ASSERT_EQ(right.size(), 5u);
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(ReadImage(left[size_t(i)], ImageColor::kColor).at<cv::Vec3b>(0, 0)[0], 10 * i);
    EXPECT_EQ(ReadImage(right[size_t(i)], ImageColor::kColor).at<cv::Vec3b>(0, 0)[0], 10 * i + 5);
  }
  std::ifstream lines(dir / "results.jsonl");
  std::string line;
  int count = 0;
  while (std::getline(lines, line)) {
    const nlohmann::json j = nlohmann::json::parse(line);
    EXPECT_EQ(j["frame"], count);
    EXPECT_EQ(j["recorded_index"], count);
    ++count;
  }
  EXPECT_EQ(count, 5);
  const StereoCalibration back = ReadStereoCalibration(dir / "stereo.yml");
  EXPECT_NEAR(back.Baseline(), 0.1, 1e-9);
}

TEST_F(RecorderTest, TheCallerMayReuseItsBuffersAtOnce) {
  Recorder recorder(8);
  const fs::path dir = recorder.Start(parent_, Calibration());
  cv::Mat left = Frame(7), right = Frame(9);
  recorder.Add(left, right, {});
  left.setTo(cv::Scalar(200, 200, 200));  // the recorder holds its own copy
  recorder.Stop();
  EXPECT_EQ(ReadImage(dir / "left" / "000000.png", ImageColor::kColor).at<cv::Vec3b>(0, 0)[0], 7);
}

TEST_F(RecorderTest, ASecondRecordingGetsAFolderOfItsOwn) {
  Recorder recorder;
  const fs::path first = recorder.Start(parent_, Calibration());
  recorder.Add(Frame(1), Frame(2), {});
  const fs::path second = recorder.Start(parent_, Calibration());  // stops the first
  EXPECT_NE(first, second);
  recorder.Stop();
  EXPECT_TRUE(fs::exists(first / "left" / "000000.png"));
  EXPECT_FALSE(fs::exists(second / "left" / "000000.png"));
}

TEST_F(RecorderTest, AFolderThatCannotBeCreatedIsNamed) {
  fs::create_directories(parent_);
  std::ofstream(parent_ / "file") << "x";
  Recorder recorder;
  try {
    recorder.Start(parent_ / "file", Calibration());
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("file"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(recorder.on());
}

}  // namespace
}  // namespace linesight
