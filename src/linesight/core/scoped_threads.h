// Thread counts of library calls. ScopedOpenCvThreads sizes OpenCV's thread pool for one call and
// restores the caller's setting afterwards, so that a library call with `threads = N` never changes
// the process-wide cv::setNumThreads.
#pragma once

#include <algorithm>
#include <thread>

#include <opencv2/core/utility.hpp>

namespace linesight {

// The number of threads a call with option `threads = requested` uses: requested if > 0, else one
// per hardware thread (at least 1).
inline int ResolveThreadCount(int requested) {
  if (requested > 0) return requested;
  return static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

class ScopedOpenCvThreads {
 public:
  // threads = 0 keeps the current setting (all cores unless the caller chose otherwise).
  explicit ScopedOpenCvThreads(int threads) : saved_(cv::getNumThreads()), active_(threads > 0) {
    if (active_) cv::setNumThreads(threads);
  }
  ~ScopedOpenCvThreads() {
    if (active_) cv::setNumThreads(saved_);
  }
  ScopedOpenCvThreads(const ScopedOpenCvThreads&) = delete;
  ScopedOpenCvThreads& operator=(const ScopedOpenCvThreads&) = delete;

 private:
  int saved_;
  bool active_;
};

}  // namespace linesight
