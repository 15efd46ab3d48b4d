// Test helper: writes tiny synthetic scenes in the Middlebury 2001 layout (imL.png imR.png
// groundtruth.png nonocc.png all.png disc.png info.txt) — a blurred random texture shifted by a
// constant disparity, so every matcher should find it.
#pragma once

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <unistd.h>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace linesight::testing {

// A fresh temporary folder per test (named after the test and the process), removed afterwards.
class ScopedTempDir {
 public:
  ScopedTempDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = std::filesystem::temp_directory_path() /
            (std::string("linesight_eval_") + info->test_suite_name() + "_" + info->name() + "_" +
             std::to_string(::getpid()));
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~ScopedTempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  ScopedTempDir(const ScopedTempDir&) = delete;
  ScopedTempDir& operator=(const ScopedTempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

// Blurred random BGR texture of `size`, deterministic for `seed`.
inline cv::Mat SyntheticTexture(cv::Size size, int seed) {
  cv::RNG rng(static_cast<uint64_t>(seed));
  cv::Mat texture(size, CV_8UC3);
  rng.fill(texture, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(texture, texture, cv::Size(0, 0), 0.8);
  return texture;
}

// One scene folder `dir` of width x height with constant disparity `disparity` (px, integer):
// left(x) = right(x - d). Ground truth scale 4, ndisp `num_disparities` (info.txt). The first `d`
// columns have no match (occluded: left out of nonocc).
inline void WriteSyntheticMiddlebury2001Scene(const std::filesystem::path& dir, int width,
                                              int height, int disparity, int num_disparities,
                                              int seed) {
  std::filesystem::create_directories(dir);
  const cv::Mat texture = SyntheticTexture(cv::Size(width + disparity, height), seed);
  const cv::Mat right = texture(cv::Rect(disparity, 0, width, height)).clone();
  const cv::Mat left = texture(cv::Rect(0, 0, width, height)).clone();
  cv::Mat gt(height, width, CV_8UC1, cv::Scalar(disparity * 4));
  cv::Mat all(height, width, CV_8UC1, cv::Scalar(255));
  cv::Mat nonocc = all.clone();
  nonocc(cv::Rect(0, 0, disparity, height)).setTo(0);
  cv::Mat disc(height, width, CV_8UC1, cv::Scalar(0));
  cv::imwrite((dir / "imL.png").string(), left);
  cv::imwrite((dir / "imR.png").string(), right);
  cv::imwrite((dir / "groundtruth.png").string(), gt);
  cv::imwrite((dir / "nonocc.png").string(), nonocc);
  cv::imwrite((dir / "all.png").string(), all);
  cv::imwrite((dir / "disc.png").string(), disc);
  std::ofstream((dir / "info.txt").string()) << "4\n" << num_disparities << "\n";
}

// <root>/middlebury-2001-2003/{alpha,beta}: 160x48, disparities 5 and 9, ndisp 64.
inline std::filesystem::path WriteTwoSyntheticScenes(const std::filesystem::path& root) {
  const std::filesystem::path set = root / "middlebury-2001-2003";
  WriteSyntheticMiddlebury2001Scene(set / "alpha", 160, 48, 5, 64, 1);
  WriteSyntheticMiddlebury2001Scene(set / "beta", 160, 48, 9, 64, 2);
  return root;
}

}  // namespace linesight::testing
