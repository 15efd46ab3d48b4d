// The base station: a live ranging loop over a FrameSource and the HTTP server that shows it
// (`linesight serve`). The loop grabs a pair, rectifies, matches, ranges the user's ROIs (filtered
// over time by DistanceTracker) and finds obstacles automatically - by default the obstacles on the
// robot's conductor (FindLineObstacles: the conductor model, each obstacle's type and distance
// along the line, tracked by LineTracker with approach rate and time to reach; an alarm when the
// nearest is within the alarm distance along the line), or for rigs that do not ride a line every
// region thicker than a conductor at its own depth (RangeAuto, filtered by DistanceTracker) - and
// publishes the newest result; the server hands it to the web page (web/index.html, embedded) and
// to any client through a JSON API:
//
//   GET  /                    the base-station page
//   GET  /api/status          source, calibration summary, frame index, fps, latency, settings
//   GET  /api/result          newest frame's obstacles: per-frame measurements and the filtered
//                             tracks (confirmed ones seen in this frame, and every ROI track);
//                             in line mode "line": the conductor (status, image curve), this
//                             frame's obstacles, the tracks nearest along the line first, the
//                             alarm distance and whether the nearest track is within it
//   GET  /api/frame/left.jpg  newest rectified left image (JPEG)
//   GET  /api/frame/disparity.jpg  its disparity, colour-mapped (JPEG)
//   POST /api/rois            {"rois": [[x, y, w, h], ...], "auto": true|false}: set what is ranged
//   POST /api/alarm           {"distance_m": x}: the alarm distance along the line (m)
//   POST /api/pause, /api/resume
//
// Every API error answers 4xx with {"error": "<what is wrong>"}: 404 for an unknown path, 405 (with
// Allow) for a known path with the wrong method, 415 for a POST whose Content-Type is not
// application/json (a page of another origin cannot send that without a CORS preflight, which is
// never granted), 401 for a POST without the access token when one is set, 413 for a body over
// 64 kB. The HTTP layer only parses and presents; all work is in the library.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "linesight/acquire/frame_source.h"
#include "linesight/line/line_obstacles.h"
#include "linesight/line/line_tracker.h"
#include "linesight/ranging/pipeline.h"
#include "linesight/server/api_request.h"
#include "linesight/server/distance_tracker.h"

namespace linesight {

// How obstacles are found automatically.
enum class AutoFinder {
  kLine,     // the obstacles on the robot's conductor (line/line_obstacles.h)
  kRegions,  // every region thicker than a conductor at its own depth (RangingPipeline::RangeAuto)
};
std::string AutoFinderName(AutoFinder finder);        // "line", "regions"
AutoFinder ParseAutoFinder(const std::string& name);  // UsageError listing the names

struct BaseStationOptions {
  RangingPipelineOptions pipeline;
  DistanceTrackerOptions tracker;
  std::vector<cv::Rect> rois;  // user ROIs (rectified left pixels)
  bool auto_detect = true;     // also find obstacles automatically
  AutoFinder finder = AutoFinder::kLine;
  LineObstacleOptions line;
  LineTrackerOptions line_tracker;
  // An obstacle on the line nearer than this along the line raises the alarm (m, 0.05..100).
  double alarm_distance_m = 1.0;
  // Automatic detections whose sigma_m exceeds this share of their distance are reported but not
  // tracked: fragments of background structure whose depth the ranging cannot pin down (> 0).
  double max_auto_relative_sigma = 0.05;
  int jpeg_quality = 85;   // 1..100
  double max_fps = 0;      // processing rate cap (0 = as fast as possible)
  int64_t max_frames = 0;  // stop after this many frames (0 = until the source ends)

  void Check() const;
};

// The newest published result.
struct BaseStationSnapshot {
  int64_t frame_index = -1;  // -1 until the first frame is processed
  double timestamp_s = 0;
  double process_ms = 0;  // rectify + match + range of this frame
  double fps = 0;         // processed frames per second (moving average)
  std::vector<uint8_t> left_jpeg, disparity_jpeg;
  nlohmann::json result;  // measurements and tracks of this frame
};

class BaseStation {
 public:
  // Throws InputError when the source gives no calibration and `calibration` is empty, or the
  // calibration does not match the source's image size.
  BaseStation(std::unique_ptr<FrameSource> source, std::optional<StereoCalibration> calibration,
              const BaseStationOptions& options);
  ~BaseStation();
  BaseStation(const BaseStation&) = delete;
  BaseStation& operator=(const BaseStation&) = delete;

  // Starts the processing thread.
  void Start();
  // Stops it and waits (idempotent).
  void Stop();
  // Asks the loop to stop after the frame it is processing, without waiting; running() turns false
  // when it has.
  void RequestStop();
  // Processes one frame on the calling thread (what the thread does in a loop). Returns false
  // when the source has ended.
  bool Step();
  // Blocks until a frame newer than `after` is published, the loop ends, or the timeout passes.
  // Returns the newest frame index.
  int64_t WaitForFrame(int64_t after, double timeout_s) const;

  BaseStationSnapshot Snapshot() const;
  nlohmann::json Status() const;
  void SetRois(const RoiRequest& request);
  void SetAlarmDistance(double distance_m);  // OptionError outside 0.05..100 m
  void SetPaused(bool paused);
  bool running() const { return running_.load(); }
  // The error that ended the loop (a camera that stopped), empty otherwise.
  std::string error() const;
  cv::Size image_size() const { return image_size_; }

 private:
  void Loop();

  std::unique_ptr<FrameSource> source_;
  BaseStationOptions options_;
  std::unique_ptr<RangingPipeline> pipeline_;
  std::string calibration_summary_;
  cv::Size image_size_;
  std::optional<StereoFrame> first_frame_;

  mutable std::mutex mutex_;  // guards everything below
  mutable std::condition_variable published_;
  BaseStationSnapshot snapshot_;
  std::vector<cv::Rect> rois_;
  bool auto_detect_ = true;
  bool settings_changed_ = false;
  bool paused_ = false;
  std::string error_;
  DistanceTracker tracker_;
  LineTracker line_tracker_;
  ConductorModel conductor_;  // the last frame's, seeds the next fit
  double alarm_distance_m_ = 1.0;
  double fps_ = 0;
  double last_publish_s_ = -1;

  std::atomic<bool> running_{false};
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

struct BaseStationServerOptions {
  // When not empty, every state-changing request (POST) must carry "Authorization: Bearer
  // <token>" (401 otherwise). `serve` requires one to listen on anything but loopback.
  std::string token;
  // Seconds a connection may stall mid-request, or idle between keep-alive requests, before it is
  // closed: bounds how long a half-sent request holds a worker, and so the exit after Stop().
  int io_timeout_s = 1;
  int workers = 32;  // concurrent connections served (each poller holds one)

  void Check() const;
};

// The HTTP front end of a BaseStation.
class BaseStationServer {
 public:
  explicit BaseStationServer(BaseStation* station, const BaseStationServerOptions& options = {});
  ~BaseStationServer();
  BaseStationServer(const BaseStationServer&) = delete;
  BaseStationServer& operator=(const BaseStationServer&) = delete;

  // Binds to host:port (port 0 = any free port) and returns the port; throws InputError when the
  // address cannot be bound.
  int Bind(const std::string& host, int port);
  // Serves until Stop() (blocking).
  void Listen();
  void Stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// The embedded web page (web/index.html).
const std::string& BaseStationPage();

}  // namespace linesight
