#include "linesight/server/base_station.h"

#include <httplib.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <memory>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <opencv2/imgproc.hpp>

#include "linesight/core/error.h"
#include "linesight/core/timer.h"
#include "linesight/io/annotate.h"
#include "linesight/io/disparity_io.h"
#include "linesight/io/image_codecs.h"
#include "linesight/server/web_page.h"

namespace linesight {
namespace {

using Clock = std::chrono::steady_clock;

// GET /api/fault/<id>.jpg: the crops of the kept faults.
constexpr const char* kFaultCropPrefix = "/api/fault/";

JpegBytes EncodeJpeg(const cv::Mat& image, int quality) {
  auto bytes = std::make_shared<std::vector<uint8_t>>();
  if (!detail::EncodeJpeg(image, quality, bytes.get())) {
    throw std::runtime_error(fmt::format("cannot encode a {}x{} image of type {} as JPEG",
                                         image.cols, image.rows, image.type()));
  }
  return bytes;
}

// Exponential moving average over about five frames; the first value starts it.
void Smooth(double* average, double value, bool first) {
  *average = first ? value : 0.8 * *average + 0.2 * value;
}

nlohmann::json RectToJson(const cv::Rect& r) { return {r.x, r.y, r.width, r.height}; }

}  // namespace

std::string AutoFinderName(AutoFinder finder) {
  return finder == AutoFinder::kLine ? "line" : "regions";
}

AutoFinder ParseAutoFinder(const std::string& name) {
  if (name == "line") return AutoFinder::kLine;
  if (name == "regions") return AutoFinder::kRegions;
  throw UsageError(fmt::format("automatic finder '{}': expected line or regions", name));
}

void BaseStationOptions::Check() const {
  pipeline.Check();
  tracker.Check();
  line.Check();
  line_tracker.Check();
  faults.Check();
  fault_log.Check();
  CheckOption(alarm_distance_m >= 0.05 && alarm_distance_m <= 100,
              "BaseStationOptions.alarm_distance_m", alarm_distance_m, "must be in [0.05, 100] m");
  CheckOption(jpeg_quality >= 1 && jpeg_quality <= 100, "BaseStationOptions.jpeg_quality",
              jpeg_quality, "must be in 1..100");
  CheckOption(max_auto_relative_sigma > 0, "BaseStationOptions.max_auto_relative_sigma",
              max_auto_relative_sigma, "must be > 0");
  CheckOption(max_fps >= 0, "BaseStationOptions.max_fps", max_fps, "must be >= 0 (0 = no cap)");
  CheckOption(max_frames >= 0, "BaseStationOptions.max_frames", max_frames,
              "must be >= 0 (0 = until the source ends)");
  CheckOption(!record_dir.empty(), "BaseStationOptions.record_dir", record_dir,
              "must name a folder");
  CheckOption(health_every_frames >= 1, "BaseStationOptions.health_every_frames",
              health_every_frames, "must be >= 1");
  row_alignment.Check();
}

nlohmann::json StageTimes::ToJson() const {
  return {{"grab", grab},       {"rectify", rectify}, {"match", match},   {"range", range},
          {"inspect", inspect}, {"health", health},   {"encode", encode}, {"latency", latency}};
}

BaseStation::BaseStation(std::unique_ptr<FrameSource> source,
                         std::optional<StereoCalibration> calibration,
                         const BaseStationOptions& options)
    : source_(std::move(source)),
      options_(options),
      rois_(options.rois),
      auto_detect_(options.auto_detect),
      tracker_(options.tracker),
      line_tracker_(options.line_tracker),
      fault_log_(options.fault_log),
      alarm_distance_m_(options.alarm_distance_m) {
  options_.Check();
  if (!calibration) calibration = source_->Calibration();
  if (!calibration) {
    throw InputError(fmt::format("source '{}' has no calibration of its own: give --calib",
                                 source_->Describe()));
  }
  // The first frame tells the image size; it is processed first.
  first_frame_ = source_->Read();
  if (!first_frame_) {
    throw InputError(fmt::format("source '{}' delivered no frame", source_->Describe()));
  }
  image_size_ = first_frame_->left.size();
  CheckCalibrationMatchesImage(*calibration, image_size_, "the calibration");
  for (const cv::Rect& roi : rois_) CheckRoi(roi, image_size_);
  RangingPipelineOptions pipeline_options = options_.pipeline;
  if (options_.finder == AutoFinder::kLine) {
    pipeline_options.params = LineMatcherParams(pipeline_options.method, pipeline_options.params);
  }
  pipeline_ = std::make_unique<RangingPipeline>(*calibration, pipeline_options);
  calibration_ = *calibration;
  calibration_summary_ =
      fmt::format("{}x{}, rectified f {:.1f} px, baseline {:.1f} mm", image_size_.width,
                  image_size_.height, pipeline_->rectified_calibration().RectifiedFocal(),
                  1000 * pipeline_->rectified_calibration().Baseline());
}

BaseStation::~BaseStation() { Stop(); }

void BaseStation::Start() {
  if (running_.exchange(true)) return;
  stop_ = false;
  thread_ = std::thread([this] { Loop(); });
}

void BaseStation::RequestStop() {
  stop_ = true;
  published_.notify_all();
}

void BaseStation::Stop() {
  RequestStop();
  if (thread_.joinable()) thread_.join();
  running_ = false;
}

void BaseStation::Loop() {
  try {
    if (options_.overlap) {
      LoopOverlapped();
    } else {
      LoopSequential();
    }
  } catch (const std::exception& e) {
    std::lock_guard lock(mutex_);
    if (error_.empty()) error_ = e.what();
  }
  running_ = false;
  published_.notify_all();
}

bool BaseStation::Paused() const {
  std::lock_guard lock(mutex_);
  return paused_;
}

// Waits while paused; false when asked to stop.
bool BaseStation::WaitWhilePaused() {
  std::unique_lock lock(mutex_);
  while (paused_ && !stop_) published_.wait_for(lock, std::chrono::milliseconds(100));
  return !stop_;
}

bool BaseStation::LastFrameReached(int64_t frame_index) const {
  return options_.max_frames > 0 && frame_index + 1 >= options_.max_frames;
}

void BaseStation::LoopSequential() {
  while (WaitWhilePaused()) {
    const auto started = Clock::now();
    std::optional<MatchedFrame> matched = GrabAndMatch();
    if (!matched) break;
    const int64_t index = matched->frame.index;
    RangeAndPublish(std::move(*matched));
    if (LastFrameReached(index)) break;
    if (options_.max_fps > 0) {
      std::this_thread::sleep_until(started +
                                    std::chrono::duration<double>(1.0 / options_.max_fps));
    }
  }
}

// Two stages on two threads: a grabber that reads, rectifies and matches the next pair while this
// thread ranges, tracks, encodes and publishes the previous one. The grabber starts on a pair only
// when the ranging has taken the one before, so at most one matched pair ever waits: the newest
// pair the source has is the one processed (latest frame first), nothing queues up latency (a
// result is published at most two frame times after its pair was in hand), and a recorded source
// still has every frame processed.
void BaseStation::LoopOverlapped() {
  std::mutex handoff_mutex;
  std::condition_variable handoff_changed;
  std::optional<MatchedFrame> handoff;
  bool grabber_done = false, halt = false;
  std::string grabber_error;
  std::thread grabber([&] {
    try {
      while (WaitWhilePaused()) {
        {
          std::unique_lock lock(handoff_mutex);
          handoff_changed.wait(lock, [&] { return !handoff || halt; });
          if (halt) break;
        }
        const auto started = Clock::now();
        std::optional<MatchedFrame> matched = GrabAndMatch();
        if (!matched) break;
        const int64_t index = matched->frame.index;
        {
          std::lock_guard lock(handoff_mutex);
          handoff = std::move(matched);
        }
        handoff_changed.notify_all();
        if (LastFrameReached(index)) break;
        if (options_.max_fps > 0) {
          std::this_thread::sleep_until(started +
                                        std::chrono::duration<double>(1.0 / options_.max_fps));
        }
      }
    } catch (const std::exception& e) {
      std::lock_guard lock(handoff_mutex);
      grabber_error = e.what();
    }
    {
      std::lock_guard lock(handoff_mutex);
      grabber_done = true;
    }
    handoff_changed.notify_all();
  });
  const auto stop_grabber = [&] {
    {
      std::lock_guard lock(handoff_mutex);
      halt = true;
    }
    handoff_changed.notify_all();
    grabber.join();
  };
  try {
    // A pause holds at the frame being ranged: a matched pair waiting for the ranging, also one
    // whose matching ends after the pause, is not taken until the station resumes.
    while (WaitWhilePaused()) {
      std::optional<MatchedFrame> matched;
      {
        std::unique_lock lock(handoff_mutex);
        // Woken at least every 100 ms to see a stop request.
        while (!handoff && !grabber_done && !stop_) {
          handoff_changed.wait_for(lock, std::chrono::milliseconds(100));
        }
        if (!handoff) break;  // the grabber ended (source ended or failed) or a stop was asked
        if (Paused()) continue;
        matched = std::move(handoff);
        handoff.reset();
      }
      handoff_changed.notify_all();
      const int64_t index = matched->frame.index;
      RangeAndPublish(std::move(*matched));
      if (LastFrameReached(index) || stop_) break;
    }
  } catch (...) {
    stop_grabber();
    throw;
  }
  stop_grabber();
  if (!grabber_error.empty()) throw InputError(grabber_error);
}

bool BaseStation::Step() {
  std::optional<MatchedFrame> matched = GrabAndMatch();
  if (!matched) return false;
  RangeAndPublish(std::move(*matched));
  return true;
}

std::optional<BaseStation::MatchedFrame> BaseStation::GrabAndMatch() {
  Stopwatch grab_watch;
  std::optional<StereoFrame> frame;
  if (first_frame_) {
    frame = std::move(first_frame_);
    first_frame_.reset();
  } else {
    frame = source_->Read();
  }
  if (!frame) return std::nullopt;
  MatchedFrame matched;
  matched.stages.grab = grab_watch.ElapsedMs();
  matched.in_hand.Restart();  // the latency runs from here to the publication
  if (frame->left.size() != image_size_) {
    throw InputError(fmt::format("source '{}': frame {} is {}x{}, the stream started at {}x{}",
                                 source_->Describe(), frame->index, frame->left.cols,
                                 frame->left.rows, image_size_.width, image_size_.height));
  }
  matched.ranged = pipeline_->Process(frame->left, frame->right);
  matched.stages.rectify = matched.ranged.rectify_ms;
  matched.stages.match = matched.ranged.match_ms;
  matched.frame = std::move(*frame);
  return matched;
}

void BaseStation::RangeAndPublish(MatchedFrame matched) {
  const StereoFrame* frame = &matched.frame;
  const RangingFrame& ranged = matched.ranged;
  StageTimes& stages = matched.stages;
  std::vector<cv::Rect> rois;
  bool automatic = false;
  {
    std::lock_guard lock(mutex_);
    rois = rois_;
    automatic = auto_detect_;
    if (settings_changed_) {
      tracker_.Reset();
      line_tracker_ = LineTracker(options_.line_tracker);
      settings_changed_ = false;
    }
  }
  const bool line_mode = automatic && options_.finder == AutoFinder::kLine;

  Stopwatch watch;
  std::vector<RangeResult> results = pipeline_->RangeRois(ranged, rois);
  const size_t num_roi = results.size();
  if (automatic && !line_mode) {
    for (RangeResult& r : pipeline_->RangeAuto(ranged)) results.push_back(std::move(r));
  }
  LineObstacles on_line;
  if (line_mode) {
    on_line = FindLineObstacles(*pipeline_, ranged, options_.line,
                                conductor_.ok() ? &conductor_ : nullptr);
    conductor_ = on_line.conductor;
  }
  stages.range = watch.ElapsedMs();

  // The conductor inspected on the same frame, with the matcher's checked disparity as
  // `linesight inspect` does; the crops are encoded here, outside the lock.
  const bool inspect = line_mode && options_.inspect;
  std::optional<ConductorInspection> inspection;
  std::vector<JpegBytes> fault_crops;
  if (inspect) {
    watch.Restart();
    inspection =
        InspectConductor(ranged.left_rectified, ranged.right_rectified, ranged.checked_disparity,
                         on_line, pipeline_->geometry(), options_.faults);
    for (const ConductorFault& f : inspection->faults) {
      fault_crops.push_back(EncodeFaultCrop(ranged.left_rectified, f.box, options_.fault_log));
    }
    stages.inspect = watch.ElapsedMs();
  }
  const double process_ms = stages.rectify + stages.match + stages.range + stages.inspect;

  // Calibration health, on the first frame and every health_every_frames after it.
  std::optional<RowAlignment> health;
  if (frames_processed_ % options_.health_every_frames == 0) {
    watch.Restart();
    health =
        MeasureRowAlignment(ranged.left_rectified, ranged.right_rectified, options_.row_alignment);
    stages.health = watch.ElapsedMs();
  }

  std::vector<DistanceMeasurement> measurements;
  nlohmann::json measured = nlohmann::json::array();
  for (size_t i = 0; i < results.size(); ++i) {
    const RangeResult& r = results[i];
    const bool roi = i < num_roi;
    const bool trackable = r.ok() && r.sigma_m > 0 &&
                           (roi || r.sigma_m <= options_.max_auto_relative_sigma * r.distance_m);
    nlohmann::json j = RangeResultToJson(r);
    j["source"] = roi ? "roi" : "auto";
    if (roi) j["roi_index"] = i;
    j["tracked"] = trackable;
    measured.push_back(std::move(j));
    if (trackable) {
      measurements.push_back(
          {roi ? fmt::format("roi:{}", i) : std::string(), r.box, r.distance_m, r.sigma_m});
    }
  }

  nlohmann::json result;
  {
    std::lock_guard lock(mutex_);
    const std::vector<TrackState> tracks = tracker_.Update(frame->timestamp_s, measurements);
    nlohmann::json tracked = nlohmann::json::array();
    int tentative = 0;
    for (const TrackState& t : tracks) {
      // Reported: confirmed tracks measured in this frame, and every ROI track. An automatic track
      // that missed this frame coasts (for re-association) but is not shown: its predicted sigma
      // grows with every frame it is not seen.
      if (t.confirmed && (t.missed == 0 || t.key != "auto")) {
        tracked.push_back(t.ToJson());
      } else {
        ++tentative;
      }
    }
    result = {{"frame", frame->index},
              {"timestamp_s", frame->timestamp_s},
              {"process_ms", process_ms},
              {"measurements", measured},
              {"tracks", tracked},
              {"tentative_tracks", tentative},
              {"distance_definition",
               "depth of the obstacle's nearest visible surface along the rectified left "
               "optical axis (m)"}};
    if (line_mode) {
      // The line tracker runs under the lock: a settings change resets it from another thread.
      const std::vector<LineTrack> line_tracks =
          line_tracker_.Update(frame->timestamp_s, on_line.obstacles);
      nlohmann::json list = nlohmann::json::array();
      for (const LineTrack& t : line_tracks) list.push_back(t.ToJson());
      nlohmann::json found = on_line.ToJson();
      const bool alarm = !line_tracks.empty() && line_tracks.front().arc_m <= alarm_distance_m_;
      result["line"] = {
          {"conductor", found["conductor"]},
          {"obstacles", found["obstacles"]},
          {"tracks", list},
          {"alarm_distance_m", alarm_distance_m_},
          {"alarm", alarm},
          {"distance_definition",
           "arc_m: distance along the conductor from the robot to the obstacle's near "
           "end (m); distance_m: depth of its nearest visible surface (m)"}};
      result["line"]["inspection"] =
          inspection
              ? LogFaults(*inspection, line_tracks, frame->index, frame->timestamp_s, fault_crops)
              : nlohmann::json{{"status", "off"},
                               {"reason", "the conductor is not inspected (--no-inspect)"},
                               {"faults", nlohmann::json::array()},
                               {"in_frame", nlohmann::json::array()}};
    }
  }

  // Colour map of the working range only (farther = black), scaled to what is in view.
  watch.Restart();
  const DisparityRange range = pipeline_->disparity_range();
  cv::Mat in_range = ranged.disparity.clone();
  in_range.setTo(std::numeric_limits<float>::infinity(),
                 (in_range < range.min_disparity) | (in_range > range.max_disparity()));
  JpegBytes left_jpeg = EncodeJpeg(ranged.left_rectified, options_.jpeg_quality);
  JpegBytes disparity_jpeg = EncodeJpeg(ColorizeDisparity(in_range), options_.jpeg_quality);
  JpegBytes annotated_jpeg =
      annotated_viewers_.load() > 0 ? DrawAnnotated(ranged.left_rectified, result) : nullptr;
  stages.encode = watch.ElapsedMs();

  {
    std::lock_guard lock(mutex_);
    const Clock::time_point now = Clock::now();
    if (last_publish_) {
      const double seconds = std::chrono::duration<double>(now - *last_publish_).count();
      if (seconds > 0) Smooth(&fps_, 1.0 / seconds, fps_ == 0);
    }
    last_publish_ = now;
    if (health) {
      health_ = *health;
      health_frame_ = frame->index;
      if (health->verdict != RowAlignment::Verdict::kNoVerdict) {
        health_history_.emplace_back(frame->index, health->median_abs_offset_px);
        if (health_history_.size() > 60) health_history_.pop_front();
      }
    }
    stages.latency = matched.in_hand.ElapsedMs();
    const bool first = frames_processed_ == 0;
    for (auto [average, value] : {std::pair{&stage_average_.grab, stages.grab},
                                  {&stage_average_.rectify, stages.rectify},
                                  {&stage_average_.match, stages.match},
                                  {&stage_average_.range, stages.range},
                                  {&stage_average_.inspect, stages.inspect},
                                  {&stage_average_.health, stages.health},
                                  {&stage_average_.encode, stages.encode},
                                  {&stage_average_.latency, stages.latency}}) {
      Smooth(average, value, first);
    }
    ++frames_processed_;
    result["stages_ms"] = stages.ToJson();
    snapshot_.frame_index = frame->index;
    snapshot_.timestamp_s = frame->timestamp_s;
    snapshot_.process_ms = process_ms;
    snapshot_.fps = fps_;
    snapshot_.stages = stages;
    snapshot_.left_jpeg = std::move(left_jpeg);
    snapshot_.disparity_jpeg = std::move(disparity_jpeg);
    snapshot_.annotated_jpeg = std::move(annotated_jpeg);
    snapshot_.result = result;
  }
  published_.notify_all();
  recorder_.Add(frame->left, frame->right, result);
}

// Feeds the frame's faults to the fault log (under the lock) and returns the result's
// "inspection": the inspection's summary, this frame's faults with the id each was merged into, and
// the faults kept. The robot's speed along the line is the median approach rate of the tracked
// obstacles, which are fixed to the line like the faults.
nlohmann::json BaseStation::LogFaults(const ConductorInspection& inspection,
                                      const std::vector<LineTrack>& line_tracks, int64_t frame,
                                      double timestamp_s, const std::vector<JpegBytes>& crops) {
  std::optional<double> speed;
  if (!line_tracks.empty()) {
    std::vector<double> rates;
    for (const LineTrack& t : line_tracks) rates.push_back(t.approach_mps);
    std::nth_element(rates.begin(), rates.begin() + long(rates.size() / 2), rates.end());
    speed = rates[rates.size() / 2];
  }
  const std::vector<int> ids =
      fault_log_.Update(frame, timestamp_s, inspection.faults, crops, speed);
  nlohmann::json j = inspection.ToJson();
  j["reason"] = inspection.reason;
  nlohmann::json in_frame = nlohmann::json::array();
  for (size_t i = 0; i < inspection.faults.size(); ++i) {
    nlohmann::json f = inspection.faults[i].ToJson();
    f["id"] = ids[i];
    in_frame.push_back(std::move(f));
  }
  j.erase("faults");
  j["in_frame"] = std::move(in_frame);
  nlohmann::json kept = nlohmann::json::array();
  for (const LoggedFault& f : fault_log_.faults()) kept.push_back(f.ToJson(kFaultCropPrefix));
  j["faults"] = std::move(kept);
  j["max_faults"] = fault_log_.options().max_faults;
  j["robot_speed_mps"] = fault_log_.robot_speed_mps();
  j["definition"] =
      "faults: the faults seen recently, the most recently seen first, merged over frames by their "
      "arc along the line; arc_m: arc from the robot to the fault's centre at its last sighting "
      "(m); arc_now_m: where it is expected now (m, < 0 = passed); length_m: its extent along the "
      "line; size_m: its size (m): a bird-cage's radius increase, a nest's or sheet's extent, how "
      "far "
      "a tilted damper's weights have swung aside (roll_deg: its roll about the line, deg); "
      "in_frame: this frame's faults, with the id of the "
      "kept fault each was merged into";
  return j;
}

JpegBytes BaseStation::DrawAnnotated(const cv::Mat& left_rectified,
                                     const nlohmann::json& result) const {
  cv::Mat view;
  if (left_rectified.channels() == 1) {
    cv::cvtColor(left_rectified, view, cv::COLOR_GRAY2BGR);
  } else {
    view = left_rectified.clone();
  }
  const auto box_of = [](const nlohmann::json& b) {
    return cv::Rect(b[0].get<int>(), b[1].get<int>(), b[2].get<int>(), b[3].get<int>());
  };
  if (result.contains("line")) {
    const nlohmann::json& line = result["line"];
    const nlohmann::json& conductor = line["conductor"];
    std::vector<std::pair<const nlohmann::json*, cv::Scalar>> curves;
    if (conductor.contains("others")) {
      for (const nlohmann::json& other : conductor["others"]) {
        curves.emplace_back(&other, cv::Scalar(255, 200, 120));
      }
    }
    if (conductor.contains("line") && !conductor["line"].is_null()) {
      curves.emplace_back(&conductor["line"], cv::Scalar(255, 224, 88));
    }
    for (const auto& [curve, colour] : curves) {
      std::vector<cv::Point> points;
      for (const nlohmann::json& p : (*curve)["image_uvd"]) {
        points.emplace_back(cvRound(p[0].get<double>()), cvRound(p[1].get<double>()));
      }
      cv::polylines(view, points, false, colour, 2, cv::LINE_AA);
    }
    const bool alarm = line["alarm"].get<bool>();
    std::vector<cv::Rect> boxes;
    std::vector<std::string> labels;
    for (const nlohmann::json& t : line["tracks"]) {
      boxes.push_back(box_of(t["box"]));
      labels.push_back(fmt::format("#{} {} {:.2f} m", t["id"].get<int>(),
                                   t["type"].get<std::string>(), t["arc_m"].get<double>()));
    }
    if (alarm && !boxes.empty()) {
      DrawLabelledBoxes(view, {boxes.front()}, {"ALARM " + labels.front()},
                        cv::Scalar(73, 81, 248));
      boxes.erase(boxes.begin());
      labels.erase(labels.begin());
    }
    DrawLabelledBoxes(view, boxes, labels, cv::Scalar(41, 180, 240));
    if (line.contains("inspection")) {
      std::vector<cv::Rect> fault_boxes;
      std::vector<std::string> fault_labels;
      for (const nlohmann::json& f : line["inspection"]["in_frame"]) {
        fault_boxes.push_back(box_of(f["box"]));
        fault_labels.push_back(fmt::format("fault {} {} {:.2f} m", f["id"].get<int>(),
                                           f["type"].get<std::string>(), f["arc_m"].get<double>()));
      }
      DrawLabelledBoxes(view, fault_boxes, fault_labels, cv::Scalar(220, 90, 230));
    }
  }
  std::vector<cv::Rect> boxes;
  std::vector<std::string> labels;
  for (const nlohmann::json& t : result["tracks"]) {
    boxes.push_back(box_of(t["box"]));
    labels.push_back(
        fmt::format("#{} {:.2f} m", t["id"].get<int>(), t["distance_m"].get<double>()));
  }
  DrawLabelledBoxes(view, boxes, labels, cv::Scalar(255, 255, 255));
  return EncodeJpeg(view, options_.jpeg_quality);
}

int64_t BaseStation::WaitForFrame(int64_t after, double timeout_s) const {
  std::unique_lock lock(mutex_);
  published_.wait_for(lock, std::chrono::duration<double>(timeout_s),
                      [&] { return snapshot_.frame_index > after || !running_.load(); });
  return snapshot_.frame_index;
}

BaseStationSnapshot BaseStation::Snapshot() const {
  std::lock_guard lock(mutex_);
  return snapshot_;
}

nlohmann::json BaseStation::Status() const {
  std::lock_guard lock(mutex_);
  nlohmann::json rois = nlohmann::json::array();
  for (const cv::Rect& r : rois_) rois.push_back(RectToJson(r));
  const DisparityRange range = pipeline_->disparity_range();
  const DisparityRange searched = pipeline_->search_range();
  // Stale: the source should be delivering (running, not paused) but the newest result is older
  // than five frame periods, and at least 2 s (a slow rig's normal gap is not an alarm).
  double age_s = -1;
  bool stale = false;
  if (last_publish_) {
    age_s = std::chrono::duration<double>(Clock::now() - *last_publish_).count();
    const double allowed = std::max(2.0, fps_ > 0 ? 5.0 / fps_ : 0.0);
    stale = running_.load() && !paused_ && age_s > allowed;
  }
  nlohmann::json calibration_health = health_.ToJson();
  calibration_health["frame"] = health_frame_;
  calibration_health["every_frames"] = options_.health_every_frames;
  nlohmann::json history = nlohmann::json::array();
  for (const auto& [frame, offset] : health_history_) history.push_back({frame, offset});
  calibration_health["history"] = history;
  return {{"source", source_->Describe()},
          {"live", source_->IsLive()},
          {"calibration", calibration_summary_},
          {"image_size", {image_size_.width, image_size_.height}},
          {"method", pipeline_->method()},
          {"working_range_m", {options_.pipeline.min_depth_m, options_.pipeline.max_depth_m}},
          {"disparity_range", {range.min_disparity, range.max_disparity()}},
          {"searched_disparities", {searched.min_disparity, searched.max_disparity()}},
          {"frame", snapshot_.frame_index},
          {"fps", snapshot_.fps},
          {"process_ms", snapshot_.process_ms},
          {"stages_ms", stage_average_.ToJson()},
          {"overlap", options_.overlap},
          {"latency_ms", stage_average_.latency},
          {"age_s", age_s},
          {"stale", stale},
          {"running", running_.load()},
          {"paused", paused_},
          {"error", error_},
          {"rois", rois},
          {"auto", auto_detect_},
          {"finder", AutoFinderName(options_.finder)},
          {"inspect", options_.finder == AutoFinder::kLine && options_.inspect},
          {"alarm_distance_m", alarm_distance_m_},
          {"calibration_health", calibration_health},
          {"recording", recorder_.Status()}};
}

void BaseStation::SetAlarmDistance(double distance_m) {
  CheckOption(distance_m >= 0.05 && distance_m <= 100, "alarm distance", distance_m,
              "must be in [0.05, 100] m");
  std::lock_guard lock(mutex_);
  alarm_distance_m_ = distance_m;
}

void BaseStation::SetRois(const RoiRequest& request) {
  std::lock_guard lock(mutex_);
  if (request.rois) rois_ = *request.rois;
  if (request.auto_detect) auto_detect_ = *request.auto_detect;
  settings_changed_ = true;
}

JpegBytes BaseStation::FaultCrop(int id) const {
  std::lock_guard lock(mutex_);
  const LoggedFault* fault = fault_log_.Find(id);
  if (fault == nullptr) {
    std::vector<int> ids;
    for (const LoggedFault& f : fault_log_.faults()) ids.push_back(f.id);
    throw InputError(fmt::format(
        "no fault {} is kept: the base station keeps the {} faults seen most recently ({})", id,
        fault_log_.options().max_faults,
        ids.empty() ? std::string("none now")
        : ids.size() <= 20
            ? fmt::format("ids now: {}", fmt::join(ids, ", "))
            : fmt::format("ids now: {}, ...", fmt::join(ids.begin(), ids.begin() + 20, ", "))));
  }
  if (!fault->crop) throw InputError(fmt::format("fault {} has no crop (its box is empty)", id));
  return fault->crop;
}

void BaseStation::SetPaused(bool paused) {
  std::lock_guard lock(mutex_);
  paused_ = paused;
  published_.notify_all();
}

void BaseStation::SetRecording(bool on) {
  if (on) {
    recorder_.Start(options_.record_dir, calibration_);
  } else {
    recorder_.Stop();
  }
}

std::string BaseStation::error() const {
  std::lock_guard lock(mutex_);
  return error_;
}

// ---------------------------------------------------------------------------------------------
// HTTP
// ---------------------------------------------------------------------------------------------

struct BaseStationServer::Impl {
  BaseStation* station;
  httplib::Server http;
};

namespace {

constexpr size_t kMaxBodyBytes = 64 * 1024;  // the API takes small JSON bodies only

void SendJson(httplib::Response& res, const nlohmann::json& j, int status = 200) {
  res.status = status;
  res.set_header("Cache-Control", "no-store");
  res.set_content(j.dump(), "application/json");
}

void SendError(httplib::Response& res, int status, const std::string& message) {
  SendJson(res, {{"error", message}}, status);
}

void SendJpeg(httplib::Response& res, const JpegBytes& bytes) {
  if (!bytes || bytes->empty()) {
    SendError(res, 503, "no frame has been processed yet");
    return;
  }
  res.set_header("Cache-Control", "no-store");
  res.set_content(reinterpret_cast<const char*>(bytes->data()), bytes->size(), "image/jpeg");
}

// How long a stream's writer waits for the next frame before it looks again (a heartbeat, a
// closed client, a server that stops): bounds the exit after Stop().
constexpr double kStreamWaitS = 0.5;

// Waits for a frame newer than `last`; while the loop is not running (not started yet, or ended)
// it returns at once, so the stream's writer sleeps out the wait instead of spinning.
int64_t WaitForNewFrame(const BaseStation* station, int64_t last) {
  const int64_t frame = station->WaitForFrame(last, kStreamWaitS);
  if (frame <= last && !station->running()) {
    std::this_thread::sleep_for(std::chrono::duration<double>(kStreamWaitS));
  }
  return frame;
}

// The server-sent event stream: "frame" for every published frame, "status" once a second
// while none is.
void StreamEvents(BaseStation* station, httplib::Response& res) {
  res.set_header("Cache-Control", "no-store");
  res.set_header("X-Accel-Buffering", "no");
  auto last = std::make_shared<int64_t>(-2);
  auto quiet_since = std::make_shared<Clock::time_point>(Clock::now());
  res.set_chunked_content_provider("text/event-stream", [station, last, quiet_since](
                                                            size_t, httplib::DataSink& sink) {
    std::string message;
    if (*last == -2) {  // first: the state as it is, so that a client draws at once
      message = fmt::format("retry: 1000\nevent: status\ndata: {}\n\n", station->Status().dump());
      *last = -1;
      return sink.write(message.data(), message.size());
    }
    const int64_t frame = WaitForNewFrame(station, *last);
    if (frame > *last) {
      const BaseStationSnapshot snap = station->Snapshot();
      *last = snap.frame_index;
      *quiet_since = Clock::now();
      message += fmt::format(
          "event: frame\ndata: {}\n\n",
          nlohmann::json{{"status", station->Status()}, {"result", snap.result}}.dump());
    } else if (Clock::now() - *quiet_since > std::chrono::seconds(1)) {
      *quiet_since = Clock::now();
      message += fmt::format("event: status\ndata: {}\n\n", station->Status().dump());
    }
    if (message.empty()) return sink.is_writable();
    return sink.write(message.data(), message.size());
  });
}

// The MJPEG stream of one view: a multipart/x-mixed-replace part per frame.
void StreamJpegs(BaseStation* station, const std::string& view, httplib::Response& res) {
  const bool annotated = view == "annotated";
  const auto pick = [view](const BaseStationSnapshot& snap) {
    return view == "left"        ? snap.left_jpeg
           : view == "disparity" ? snap.disparity_jpeg
                                 : snap.annotated_jpeg;
  };
  if (annotated) station->AddAnnotatedViewer(1);
  res.set_header("Cache-Control", "no-store");
  auto last = std::make_shared<int64_t>(-1);
  res.set_chunked_content_provider(
      "multipart/x-mixed-replace; boundary=linesightframe",
      [station, last, pick](size_t, httplib::DataSink& sink) {
        const int64_t frame = WaitForNewFrame(station, *last);
        if (frame <= *last) return sink.is_writable();
        const BaseStationSnapshot snap = station->Snapshot();
        *last = snap.frame_index;
        const JpegBytes jpeg = pick(snap);
        if (!jpeg) return sink.is_writable();  // drawn from the next frame on
        const std::string head = fmt::format(
            "--linesightframe\r\nContent-Type: image/jpeg\r\nContent-Length: {}\r\n\r\n",
            jpeg->size());
        return sink.write(head.data(), head.size()) &&
               sink.write(reinterpret_cast<const char*>(jpeg->data()), jpeg->size()) &&
               sink.write("\r\n", 2);
      },
      [station, annotated](bool) {
        if (annotated) station->AddAnnotatedViewer(-1);
      });
}

}  // namespace

void BaseStationServerOptions::Check() const {
  CheckOption(io_timeout_s >= 1 && io_timeout_s <= 60, "BaseStationServerOptions.io_timeout_s",
              io_timeout_s, "must be in 1..60 s");
  CheckOption(workers >= 2 && workers <= 1024, "BaseStationServerOptions.workers", workers,
              "must be in 2..1024");
  for (const char c : token) {
    CheckOption(c > ' ' && c < 127, "BaseStationServerOptions.token", "(hidden)",
                "must be printable ASCII without spaces");
  }
}

BaseStationServer::BaseStationServer(BaseStation* station, const BaseStationServerOptions& options)
    : impl_(std::make_unique<Impl>()) {
  options.Check();
  impl_->station = station;
  httplib::Server& http = impl_->http;
  http.set_payload_max_length(kMaxBodyBytes);
  http.set_read_timeout(options.io_timeout_s, 0);
  http.set_keep_alive_timeout(options.io_timeout_s);
  http.set_write_timeout(5, 0);
  const int workers = options.workers;
  http.new_task_queue = [workers] { return new httplib::ThreadPool(size_t(workers)); };
  // Every route and its method, filled by the registrations below: a known path asked with another
  // method answers 405.
  auto routes = std::make_shared<std::map<std::string, std::string>>();
  const std::string bearer = options.token.empty() ? "" : "Bearer " + options.token;
  http.set_pre_routing_handler([bearer, routes](const httplib::Request& req,
                                                httplib::Response& res) {
    // The fault crops are one route under a prefix (GET /api/fault/<id>.jpg).
    const bool fault_crop = req.path.rfind(kFaultCropPrefix, 0) == 0;
    const auto route = routes->find(fault_crop ? std::string(kFaultCropPrefix) : req.path);
    if (route == routes->end()) return httplib::Server::HandlerResponse::Unhandled;
    const bool allowed =
        req.method == route->second || (req.method == "HEAD" && route->second == "GET");
    if (!allowed) {
      res.set_header("Allow", route->second);
      SendError(res, 405, fmt::format("{} takes {}, not {}", req.path, route->second, req.method));
      return httplib::Server::HandlerResponse::Handled;
    }
    if (req.method != "POST") return httplib::Server::HandlerResponse::Unhandled;
    if (!bearer.empty() && req.get_header_value("Authorization") != bearer) {
      res.set_header("WWW-Authenticate", "Bearer");
      SendError(res, 401, "this server needs its access token: Authorization: Bearer <token>");
      return httplib::Server::HandlerResponse::Handled;
    }
    const std::string type = req.get_header_value("Content-Type");
    if (type.rfind("application/json", 0) != 0) {
      SendError(res, 415,
                fmt::format("{} takes Content-Type application/json, got '{}'", req.path, type));
      return httplib::Server::HandlerResponse::Handled;
    }
    return httplib::Server::HandlerResponse::Unhandled;
  });
  const auto get = [&](const std::string& path, httplib::Server::Handler handler) {
    (*routes)[path] = "GET";
    http.Get(path, std::move(handler));
  };
  const auto post = [&](const std::string& path, httplib::Server::Handler handler) {
    (*routes)[path] = "POST";
    http.Post(path, std::move(handler));
  };
  get("/", [](const httplib::Request&, httplib::Response& res) {
    res.set_content(BaseStationPage(), "text/html; charset=utf-8");
  });
  get("/favicon.ico", [](const httplib::Request&, httplib::Response& res) {
    res.status = 204;  // no icon; answered so that browsers do not log a 404
  });
  get("/api/status", [station](const httplib::Request&, httplib::Response& res) {
    SendJson(res, station->Status());
  });
  get("/api/result", [station](const httplib::Request& req, httplib::Response& res) {
    // ?after=N waits (up to 2 s) for a frame newer than N: clients poll without busy loops.
    if (req.has_param("after")) {
      const std::string text = req.get_param_value("after");
      int64_t after = 0;
      try {
        size_t used = 0;
        after = std::stoll(text, &used);
        if (used != text.size()) throw std::invalid_argument(text);
      } catch (const std::exception&) {
        SendError(res, 400, fmt::format("'after' must be an integer frame index, got '{}'", text));
        return;
      }
      station->WaitForFrame(after, 2.0);
    }
    const BaseStationSnapshot snap = station->Snapshot();
    if (snap.frame_index < 0) {
      SendError(res, 503, "no frame has been processed yet");
      return;
    }
    SendJson(res, snap.result);
  });
  get("/api/events",
      [station](const httplib::Request&, httplib::Response& res) { StreamEvents(station, res); });
  get("/api/stream.mjpeg", [station](const httplib::Request& req, httplib::Response& res) {
    const std::string view = req.has_param("view") ? req.get_param_value("view") : "annotated";
    if (view != "annotated" && view != "left" && view != "disparity") {
      SendError(res, 400,
                fmt::format("'view' must be annotated, left or disparity, got '{}'", view));
      return;
    }
    StreamJpegs(station, view, res);
  });
  get("/api/frame/left.jpg", [station](const httplib::Request&, httplib::Response& res) {
    SendJpeg(res, station->Snapshot().left_jpeg);
  });
  get("/api/frame/disparity.jpg", [station](const httplib::Request&, httplib::Response& res) {
    SendJpeg(res, station->Snapshot().disparity_jpeg);
  });
  (*routes)[kFaultCropPrefix] = "GET";
  http.Get(std::string(kFaultCropPrefix) + "([^/]*)",
           [station](const httplib::Request& req, httplib::Response& res) {
             try {
               SendJpeg(res, station->FaultCrop(ParseFaultImageName(req.matches[1].str())));
             } catch (const InputError& e) {
               SendError(res, 404, e.what());
             }
           });
  post("/api/rois", [station](const httplib::Request& req, httplib::Response& res) {
    try {
      station->SetRois(ParseRoiRequest(req.body, station->image_size()));
    } catch (const InputError& e) {
      SendError(res, 400, e.what());
      return;
    }
    SendJson(res, station->Status());
  });
  post("/api/alarm", [station](const httplib::Request& req, httplib::Response& res) {
    try {
      station->SetAlarmDistance(ParseAlarmRequest(req.body));
    } catch (const InputError& e) {
      SendError(res, 400, e.what());
      return;
    }
    SendJson(res, station->Status());
  });
  post("/api/record", [station](const httplib::Request& req, httplib::Response& res) {
    bool on = false;
    try {
      on = ParseRecordRequest(req.body);
    } catch (const InputError& e) {
      SendError(res, 400, e.what());
      return;
    }
    try {
      station->SetRecording(on);
    } catch (const InputError& e) {  // the robot's disk, not the request: a server error
      SendError(res, 500, e.what());
      return;
    }
    SendJson(res, station->Status());
  });
  post("/api/pause", [station](const httplib::Request&, httplib::Response& res) {
    station->SetPaused(true);
    SendJson(res, station->Status());
  });
  post("/api/resume", [station](const httplib::Request&, httplib::Response& res) {
    station->SetPaused(false);
    SendJson(res, station->Status());
  });
  // Errors that httplib answers itself get a JSON body too (a handler's own error keeps its own).
  http.set_error_handler([](const httplib::Request& req, httplib::Response& res) {
    if (!res.body.empty()) return;
    if (res.status == 404) {
      SendError(res, 404, fmt::format("no such resource: {} {}", req.method, req.path));
    } else if (res.status >= 400) {
      const std::string what =
          res.status == 413   ? fmt::format("the request body is over {} kB", kMaxBodyBytes / 1024)
          : res.status == 414 ? "the request URL is too long"
                              : fmt::format("the request was refused ({})", res.status);
      SendError(res, res.status, what);
    }
  });
}

BaseStationServer::~BaseStationServer() { Stop(); }

int BaseStationServer::Bind(const std::string& host, int port) {
  if (port < 0 || port > 65535) {
    throw InputError(fmt::format("port {} is not in 0..65535", port));
  }
  if (port == 0) {
    const int bound = impl_->http.bind_to_any_port(host);
    if (bound < 0) throw InputError(fmt::format("cannot listen on {} (any port)", host));
    return bound;
  }
  if (!impl_->http.bind_to_port(host, port)) {
    throw InputError(
        fmt::format("cannot listen on {}:{} (in use, or not an address of this host)", host, port));
  }
  return port;
}

void BaseStationServer::Listen() { impl_->http.listen_after_bind(); }

void BaseStationServer::Stop() {
  if (impl_) impl_->http.stop();
}

const std::string& BaseStationPage() {
  static const std::string page(kBaseStationPage);
  return page;
}

}  // namespace linesight
