// Recording of a live run: the raw pairs as grabbed and each frame's published result, written by a
// thread of its own so that a slow disk never stalls the ranging loop (frames it cannot keep up
// with are dropped and counted, never queued without bound). A recording is a folder
//
//   DIR/<UTC yyyymmdd-hhmmss>/left/000000.png ...   raw left images (as grabbed, before rectifying)
//                             right/000000.png ...  raw right images
//                             stereo.yml            the calibration the run used
//                             results.jsonl         one JSON line per recorded frame: its result
//
// that `linesight serve --source images:REC/left/*.png,REC/right/*.png --calib REC/stereo.yml`
// (or `range`, `disparity`) replays and re-processes. Images are written atomically; results.jsonl
// is flushed line by line.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <mutex>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "linesight/io/stereo_calibration.h"

namespace linesight {

class Recorder {
 public:
  // `max_queued` frames may wait for the writer (>= 1); more are dropped.
  explicit Recorder(int max_queued = 16);
  ~Recorder();  // stops (writes what is queued)
  Recorder(const Recorder&) = delete;
  Recorder& operator=(const Recorder&) = delete;

  // Starts a new recording in a new folder under `parent` (created if missing) and returns the
  // folder. Throws InputError naming the folder when it cannot be created or written. A recording
  // already running is stopped first.
  std::filesystem::path Start(const std::filesystem::path& parent,
                              const StereoCalibration& calibration);
  // Queues a copy of one frame (dropped, and counted, when the writer is `max_queued` behind).
  // Does nothing when not recording.
  void Add(const cv::Mat& left, const cv::Mat& right, const nlohmann::json& result);
  // Writes what is queued and closes the recording (idempotent).
  void Stop();

  // {"on", "dir", "frames" (written), "dropped", "error"}.
  nlohmann::json Status() const;
  bool on() const;

 private:
  struct Item {
    cv::Mat left, right;
    nlohmann::json result;
  };
  void WriteLoop();
  void StopWriter();

  const size_t max_queued_;
  std::mutex control_mutex_;  // serialises Start and Stop (requests from several clients)
  mutable std::mutex mutex_;  // guards everything below
  std::condition_variable wake_;
  std::deque<Item> queue_;
  std::filesystem::path dir_;
  bool on_ = false;
  bool closing_ = false;
  int64_t written_ = 0;
  int64_t dropped_ = 0;
  std::string error_;
  std::thread writer_;
};

}  // namespace linesight
