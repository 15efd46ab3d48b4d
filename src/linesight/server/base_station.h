// The base station: a live ranging loop over a FrameSource and the HTTP server that shows it
// (`linesight serve`). The loop grabs a pair, rectifies, matches, ranges the user's ROIs (filtered
// over time by DistanceTracker) and finds obstacles automatically - by default the obstacles on the
// robot's conductor (FindLineObstacles: the conductor model, each obstacle's type and distance
// along the line, tracked by LineTracker with approach rate and time to reach; an alarm when the
// nearest is within the alarm distance along the line), or for rigs that do not ride a line every
// region thicker than a conductor at its own depth (RangeAuto, filtered by DistanceTracker) - and
// publishes the newest result (grabbing and matching the next pair overlap with ranging the
// previous one: BaseStationOptions::overlap); the server hands it to the web page (web/index.html,
// embedded) and to any client through a JSON API:
//
//   GET  /                    the base-station page
//   GET  /api/status          source, calibration summary, frame index, fps, latency, settings
//   GET  /api/result          newest frame's obstacles: per-frame measurements and the filtered
//                             tracks (confirmed ones seen in this frame, and every ROI track);
//                             in line mode "line": the conductor (status, image curve), this
//                             frame's obstacles, the tracks nearest along the line first, the
//                             alarm distance and whether the nearest track is within it, and
//                             "inspection": the conductor inspected (status, reason, inspected
//                             length), this frame's faults and the faults seen recently, merged
//                             over frames by their arc along the line (server/fault_log.h)
//   GET  /api/events          server-sent events: "frame" {"status", "result"} for every
//                             published frame, "status" once a second while none is (so a
//                             client sees a stale, paused or ended source)
//   GET  /api/frame/left.jpg  newest rectified left image (JPEG)
//   GET  /api/frame/disparity.jpg  its disparity, colour-mapped (JPEG)
//   GET  /api/fault/<id>.jpg  a crop of the rectified left image around a kept fault at its last
//                             sighting (JPEG); 404 with the reason for an id that is not kept
//   GET  /api/stream.mjpeg    MJPEG stream (multipart/x-mixed-replace) of every frame:
//                             ?view=annotated (default: conductor, obstacles, ROIs drawn), left,
//                             disparity; plays in a browser, VLC or ffplay
//   POST /api/rois            {"rois": [[x, y, w, h], ...], "auto": true|false}: set what is ranged
//   POST /api/alarm           {"distance_m": x}: the alarm distance along the line (m)
//   POST /api/record          {"on": true|false}: start a new recording of raw pairs and results
//                             under the server's record folder (server/recorder.h), or stop it
//   POST /api/pause, /api/resume
//
// /api/status reports per-stage timing (grab, rectify, match, range, inspect, health, encode;
// moving averages, ms), the end-to-end latency from a frame in hand to its result published, the
// age of the newest result and "stale" when it is older than 5 frame periods (at least 2 s) while
// the source should be delivering, the calibration's health (row alignment of the rectified pair,
// rectify/row_alignment.h, with its recent history) and the recording's state.
//
// Every API error answers 4xx with {"error": "<what is wrong>"}: 404 for an unknown path, 405 (with
// Allow) for a known path with the wrong method, 415 for a POST whose Content-Type is not
// application/json (a page of another origin cannot send that without a CORS preflight, which is
// never granted), 401 for a POST without the access token when one is set, 413 for a body over
// 64 kB. The HTTP layer only parses and presents; all work is in the library.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "linesight/acquire/frame_source.h"
#include "linesight/core/timer.h"
#include "linesight/line/conductor_faults.h"
#include "linesight/line/line_obstacles.h"
#include "linesight/line/line_tracker.h"
#include "linesight/ranging/pipeline.h"
#include "linesight/rectify/row_alignment.h"
#include "linesight/server/api_request.h"
#include "linesight/server/distance_tracker.h"
#include "linesight/server/fault_log.h"
#include "linesight/server/recorder.h"

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
  // In line mode, inspect the conductor of every frame (InspectConductor: bird-caging) and keep
  // the faults seen recently (FaultLog, with a crop each).
  bool inspect = true;
  ConductorFaultOptions faults;
  FaultLogOptions fault_log;
  // An obstacle on the line nearer than this along the line raises the alarm (m, 0.05..100).
  double alarm_distance_m = 1.0;
  // Automatic detections whose sigma_m exceeds this share of their distance are reported but not
  // tracked: fragments of background structure whose depth the ranging cannot pin down (> 0).
  double max_auto_relative_sigma = 0.05;
  int jpeg_quality = 85;   // 1..100
  double max_fps = 0;      // processing rate cap (0 = as fast as possible)
  int64_t max_frames = 0;  // stop after this many frames (0 = until the source ends)
  // Folder under which POST /api/record starts recordings; set on the server's command line only
  // (a client cannot choose where the robot writes).
  std::string record_dir = "recordings";
  // Calibration health: the rectified pair's row alignment is measured on the first frame and then
  // every this many frames (>= 1; about 5 ms each on a 752x480 pair).
  int health_every_frames = 30;
  RowAlignmentOptions row_alignment;
  // Grab and match the next pair while this one is ranged, tracked, encoded and published (two
  // stages on two threads: on 2 cores the single-threaded ranging no longer leaves one idle). The
  // next pair is grabbed when the ranging has taken the previous one: at most one matched pair
  // waits, so latency stays within two frame times and recorded sources lose no frame. false = one
  // frame at a time.
  bool overlap = true;

  void Check() const;
};

// Wall-clock time of each stage of one frame (ms).
struct StageTimes {
  double grab = 0;     // waiting for and reading the pair from the source
  double rectify = 0;  // rectification
  double match = 0;    // dense matching
  double range = 0;    // ROIs, automatic finding, the conductor and its obstacles
  double inspect = 0;  // the conductor's inspection and its faults' crops (line mode)
  double health = 0;   // the calibration-health measure (on the frames that take it)
  double encode = 0;   // colour map and JPEG encoding for the page
  double latency = 0;  // from the pair in hand to its result published (everything but grab)

  nlohmann::json ToJson() const;
};

// The newest published result.
struct BaseStationSnapshot {
  int64_t frame_index = -1;  // -1 until the first frame is processed
  double timestamp_s = 0;
  double process_ms = 0;  // rectify + match + range + inspect of this frame
  double fps = 0;         // processed frames per second (moving average, wall clock)
  StageTimes stages;      // this frame's
  // Shared, never changed once published: readers keep them without copying.
  JpegBytes left_jpeg, disparity_jpeg;
  JpegBytes annotated_jpeg;  // only while an annotated stream has a viewer (else null)
  nlohmann::json result;     // measurements and tracks of this frame
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
  // The crop of the kept fault `id` (FaultLog). Throws InputError saying why when no fault of
  // that id is kept or it has no crop.
  JpegBytes FaultCrop(int id) const;
  void SetAlarmDistance(double distance_m);  // OptionError outside 0.05..100 m
  void SetPaused(bool paused);
  // Starts (a new folder under BaseStationOptions::record_dir) or stops recording; throws
  // InputError when the folder cannot be created.
  void SetRecording(bool on);
  // Viewers of the annotated stream: the loop draws and encodes the annotated view only while
  // there is one.
  void AddAnnotatedViewer(int delta) { annotated_viewers_ += delta; }
  bool running() const { return running_.load(); }
  // The error that ended the loop (a camera that stopped), empty otherwise.
  std::string error() const;
  cv::Size image_size() const { return image_size_; }

 private:
  using Clock = std::chrono::steady_clock;
  // The first half of a frame's work, handed from the grabbing stage to the ranging stage.
  struct MatchedFrame {
    StereoFrame frame;
    RangingFrame ranged;
    StageTimes stages;  // grab, rectify and match filled
    Stopwatch in_hand;  // started when the pair was in hand
  };
  void Loop();
  void LoopSequential();
  void LoopOverlapped();
  bool Paused() const;
  bool WaitWhilePaused();
  bool LastFrameReached(int64_t frame_index) const;
  std::optional<MatchedFrame> GrabAndMatch();  // nullopt when the source has ended
  void RangeAndPublish(MatchedFrame matched);
  JpegBytes DrawAnnotated(const cv::Mat& left_rectified, const nlohmann::json& result) const;
  nlohmann::json LogFaults(const ConductorInspection& inspection,
                           const std::vector<LineTrack>& line_tracks, int64_t frame,
                           double timestamp_s, const std::vector<JpegBytes>& crops);

  std::unique_ptr<FrameSource> source_;
  BaseStationOptions options_;
  std::unique_ptr<RangingPipeline> pipeline_;
  StereoCalibration calibration_;  // as given (what a recording replays with)
  std::string calibration_summary_;
  Recorder recorder_;
  std::atomic<int> annotated_viewers_{0};
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
  FaultLog fault_log_;
  double alarm_distance_m_ = 1.0;
  double fps_ = 0;
  std::optional<Clock::time_point> last_publish_;
  StageTimes stage_average_;  // moving averages
  int64_t frames_processed_ = 0;
  RowAlignment health_;
  int64_t health_frame_ = -1;
  std::deque<std::pair<int64_t, double>> health_history_;  // (frame, median |row offset| px)

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
  // Concurrent connections served: each event or video stream, and each poller, holds one.
  int workers = 64;

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
