#pragma once

#include <chrono>

namespace linesight {

// Wall-clock stopwatch for reports (benchmarks use Google Benchmark or `linesight bench`).
class Stopwatch {
 public:
  Stopwatch() : start_(std::chrono::steady_clock::now()) {}
  void Restart() { start_ = std::chrono::steady_clock::now(); }
  double ElapsedMs() const {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start_)
        .count();
  }

 private:
  std::chrono::steady_clock::time_point start_;
};

// Million disparity evaluations per second: width * height * disparities * fps / 1e6.
inline double MdePerSecond(int width, int height, int disparities, double ms_per_frame) {
  if (ms_per_frame <= 0) return 0;
  return static_cast<double>(width) * height * disparities * (1000.0 / ms_per_frame) / 1e6;
}

}  // namespace linesight
