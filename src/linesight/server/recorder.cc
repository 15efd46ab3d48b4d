#include "linesight/server/recorder.h"

#include <chrono>
#include <ctime>
#include <fstream>

#include <fmt/format.h>

#include "linesight/core/error.h"
#include "linesight/io/image_io.h"

namespace linesight {
namespace fs = std::filesystem;

namespace {

std::string UtcStamp() {
  const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm utc{};
  gmtime_r(&now, &utc);
  char text[32];
  std::strftime(text, sizeof text, "%Y%m%d-%H%M%S", &utc);
  return text;
}

}  // namespace

Recorder::Recorder(int max_queued) : max_queued_(size_t(std::max(1, max_queued))) {}

Recorder::~Recorder() { Stop(); }

fs::path Recorder::Start(const fs::path& parent, const StereoCalibration& calibration) {
  std::lock_guard control(control_mutex_);
  StopWriter();
  // A second recording within the same second gets a suffix rather than mixing with the first.
  fs::path dir = parent / UtcStamp();
  for (int n = 2; fs::exists(dir); ++n) dir = parent / fmt::format("{}-{}", UtcStamp(), n);
  std::error_code error;
  fs::create_directories(dir / "left", error);
  if (!error) fs::create_directories(dir / "right", error);
  if (error) {
    throw InputError(
        fmt::format("cannot create the recording folder {}: {}", dir.string(), error.message()));
  }
  WriteStereoCalibration(dir / "stereo.yml", calibration);
  std::lock_guard lock(mutex_);
  dir_ = dir;
  on_ = true;
  closing_ = false;
  written_ = dropped_ = 0;
  error_.clear();
  writer_ = std::thread([this] { WriteLoop(); });
  return dir;
}

void Recorder::Add(const cv::Mat& left, const cv::Mat& right, const nlohmann::json& result) {
  std::lock_guard lock(mutex_);
  if (!on_ || closing_) return;
  if (queue_.size() >= max_queued_) {
    ++dropped_;
    return;
  }
  queue_.push_back({left.clone(), right.clone(), result});
  wake_.notify_one();
}

void Recorder::Stop() {
  std::lock_guard control(control_mutex_);
  StopWriter();
}

void Recorder::StopWriter() {
  {
    std::lock_guard lock(mutex_);
    if (!writer_.joinable()) return;
    closing_ = true;
    wake_.notify_one();
  }
  writer_.join();
  std::lock_guard lock(mutex_);
  on_ = false;
}

void Recorder::WriteLoop() {
  fs::path dir;
  {
    std::lock_guard lock(mutex_);
    dir = dir_;
  }
  std::ofstream results(dir / "results.jsonl", std::ios::app);
  int64_t index = 0;
  for (;;) {
    Item item;
    {
      std::unique_lock lock(mutex_);
      wake_.wait(lock, [&] { return closing_ || !queue_.empty(); });
      if (queue_.empty()) return;  // closing, and everything queued is written
      item = std::move(queue_.front());
      queue_.pop_front();
    }
    try {
      const std::string name = fmt::format("{:06d}.png", index);
      WriteImage(dir / "left" / name, item.left);
      WriteImage(dir / "right" / name, item.right);
      item.result["recorded_index"] = index;
      results << item.result.dump() << '\n' << std::flush;
      if (!results)
        throw InputError(fmt::format("cannot write {}", (dir / "results.jsonl").string()));
      ++index;
      std::lock_guard lock(mutex_);
      written_ = index;
    } catch (const std::exception& e) {
      // A full or vanished disk ends the recording, not the run; the page shows why.
      std::lock_guard lock(mutex_);
      error_ = e.what();
      queue_.clear();
      closing_ = true;
      return;
    }
  }
}

nlohmann::json Recorder::Status() const {
  std::lock_guard lock(mutex_);
  return {{"on", on_ && !closing_},
          {"dir", dir_.string()},
          {"frames", written_},
          {"dropped", dropped_},
          {"error", error_}};
}

bool Recorder::on() const {
  std::lock_guard lock(mutex_);
  return on_ && !closing_;
}

}  // namespace linesight
