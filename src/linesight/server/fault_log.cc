#include "linesight/server/fault_log.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <tuple>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "linesight/core/error.h"
#include "linesight/io/image_codecs.h"

namespace linesight {

void FaultLogOptions::Check() const {
  CheckOption(max_faults >= 1 && max_faults <= 1000, "FaultLogOptions.max_faults", max_faults,
              "must be in 1..1000");
  CheckOption(gate_m > 0, "FaultLogOptions.gate_m", gate_m, "must be > 0 (m)");
  CheckOption(gate_relative >= 0, "FaultLogOptions.gate_relative", gate_relative, "must be >= 0");
  CheckOption(crop_margin_px >= 0, "FaultLogOptions.crop_margin_px", crop_margin_px,
              "must be >= 0 (px)");
  CheckOption(crop_max_px >= 16 && crop_max_px <= 2048, "FaultLogOptions.crop_max_px", crop_max_px,
              "must be in 16..2048 px");
  CheckOption(jpeg_quality >= 1 && jpeg_quality <= 100, "FaultLogOptions.jpeg_quality",
              jpeg_quality, "must be in 1..100");
}

nlohmann::json LoggedFault::ToJson(const std::string& crop_url_prefix) const {
  const cv::Rect& b = last.box;
  nlohmann::json j = {{"id", id},
                      {"type", ConductorFaultTypeName(last.type)},
                      {"arc_m", last.arc_m},
                      {"arc_now_m", arc_now_m},
                      {"length_m", last.arc_end_m - last.arc_begin_m},
                      {"arc_begin_m", last.arc_begin_m},
                      {"arc_end_m", last.arc_end_m},
                      {"distance_m", last.distance_m},
                      {"size_m", last.size_m},
                      {"confidence", last.confidence},
                      {"max_confidence", max_confidence},
                      {"box", {b.x, b.y, b.width, b.height}},
                      {"sightings", sightings},
                      {"first_seen_frame", first_seen_frame},
                      {"last_seen_frame", last_seen_frame},
                      {"first_seen_s", first_seen_s},
                      {"last_seen_s", last_seen_s},
                      {"crop", crop ? nlohmann::json(fmt::format("{}{}.jpg", crop_url_prefix, id))
                                    : nlohmann::json(nullptr)}};
  if (last.type == ConductorFaultType::kDamperTilted) j["roll_deg"] = last.roll_deg;
  return j;
}

JpegBytes EncodeFaultCrop(const cv::Mat& left_rectified, const cv::Rect& box,
                          const FaultLogOptions& options) {
  const int pad = std::max(options.crop_margin_px, std::max(box.width, box.height) / 2);
  const cv::Rect crop =
      cv::Rect(box.x - pad, box.y - pad, box.width + 2 * pad, box.height + 2 * pad) &
      cv::Rect(0, 0, left_rectified.cols, left_rectified.rows);
  if (box.empty() || crop.empty()) return nullptr;
  cv::Mat image = left_rectified(crop);
  const int longer = std::max(crop.width, crop.height);
  if (longer > options.crop_max_px) {
    const double scale = static_cast<double>(options.crop_max_px) / longer;
    cv::resize(image, image, cv::Size(), scale, scale, cv::INTER_AREA);
  }
  auto bytes = std::make_shared<std::vector<uint8_t>>();
  if (!detail::EncodeJpeg(image, options.jpeg_quality, bytes.get())) {
    throw std::runtime_error(
        fmt::format("cannot encode a {}x{} fault crop as JPEG", image.cols, image.rows));
  }
  return bytes;
}

FaultLog::FaultLog(const FaultLogOptions& options) : options_(options) { options_.Check(); }

const LoggedFault* FaultLog::Find(int id) const {
  for (const LoggedFault& f : faults_) {
    if (f.id == id) return &f;
  }
  return nullptr;
}

std::vector<int> FaultLog::Update(int64_t frame, double timestamp_s,
                                  const std::vector<ConductorFault>& faults,
                                  const std::vector<JpegBytes>& crops,
                                  std::optional<double> robot_speed_mps) {
  LS_CHECK(crops.empty() || crops.size() == faults.size());
  if (robot_speed_mps && std::isfinite(*robot_speed_mps)) speed_mps_ = *robot_speed_mps;
  // Where every kept fault is expected now.
  for (LoggedFault& f : faults_) {
    f.arc_now_m = f.last.arc_m - speed_mps_ * (timestamp_s - f.last_seen_s);
  }
  // Candidate pairs within the gate, nearest first.
  std::vector<std::tuple<double, size_t, size_t>> pairs;  // (|arc - expected|, sighting, kept)
  for (size_t s = 0; s < faults.size(); ++s) {
    const double gate = options_.gate_m + options_.gate_relative * std::max(0.0, faults[s].arc_m);
    for (size_t k = 0; k < faults_.size(); ++k) {
      const ConductorFaultType a = faults_[k].last.type, b = faults[s].type;
      if (a != b && !(IsForeignObject(a) && IsForeignObject(b))) continue;
      const double miss = std::abs(faults[s].arc_m - faults_[k].arc_now_m);
      if (miss <= gate) pairs.emplace_back(miss, s, k);
    }
  }
  std::sort(pairs.begin(), pairs.end());
  std::vector<int> ids(faults.size(), 0);
  std::vector<bool> kept_taken(faults_.size(), false);
  const auto record = [&](LoggedFault& f, size_t s) {
    f.last = faults[s];
    f.arc_now_m = faults[s].arc_m;
    ++f.sightings;
    f.max_confidence = std::max(f.max_confidence, faults[s].confidence);
    f.last_seen_frame = frame;
    f.last_seen_s = timestamp_s;
    if (!crops.empty()) f.crop = crops[s];
    ids[s] = f.id;
  };
  for (const auto& [miss, s, k] : pairs) {
    if (ids[s] != 0 || kept_taken[k]) continue;
    kept_taken[k] = true;
    record(faults_[k], s);
  }
  for (size_t s = 0; s < faults.size(); ++s) {
    if (ids[s] != 0) continue;
    LoggedFault f;
    f.id = next_id_++;
    f.first_seen_frame = frame;
    f.first_seen_s = timestamp_s;
    record(f, s);
    faults_.push_back(std::move(f));
  }
  // The most recently seen first, then nearest along the line; the ones seen longest ago drop off.
  std::stable_sort(faults_.begin(), faults_.end(), [](const LoggedFault& a, const LoggedFault& b) {
    if (a.last_seen_frame != b.last_seen_frame) return a.last_seen_frame > b.last_seen_frame;
    return a.arc_now_m < b.arc_now_m;
  });
  if (faults_.size() > static_cast<size_t>(options_.max_faults)) {
    faults_.resize(static_cast<size_t>(options_.max_faults));
  }
  return ids;
}

}  // namespace linesight
