#include "linesight/acquire/frame_source.h"

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <future>
#include <utility>

#include <fmt/format.h>
#include <opencv2/core/utils/logger.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>  // the CAP_* constants only (enums, nothing to link)

#include "linesight/core/error.h"
#include "linesight/io/image_io.h"
#include "linesight/io/opencv_plugin.h"
#include "linesight/sim/power_line_scene.h"
#include "linesight/sim/power_line_sequence.h"

namespace linesight {
namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// "a,b" -> {"a", "b"}; throws UsageError naming the source unless there are `count` non-empty
// parts (count 0 = one or two).
std::vector<std::string> SplitParts(const std::string& spec, const std::string& body, int count) {
  std::vector<std::string> parts;
  size_t start = 0;
  while (true) {
    const size_t comma = body.find(',', start);
    parts.push_back(
        body.substr(start, comma == std::string::npos ? std::string::npos : comma - start));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  const bool empty_part =
      std::any_of(parts.begin(), parts.end(), [](const std::string& p) { return p.empty(); });
  const bool count_ok = count == 0 ? (parts.size() == 1 || parts.size() == 2)
                                   : static_cast<int>(parts.size()) == count;
  if (empty_part || !count_ok) {
    throw UsageError(fmt::format("source '{}': expected {} after the scheme", spec,
                                 count == 2   ? "two comma-separated parts (LEFT,RIGHT)"
                                 : count == 1 ? "one part"
                                              : "one or two comma-separated devices"));
  }
  return parts;
}

// ---------------------------------------------------------------------------------------------
// Still images.
// ---------------------------------------------------------------------------------------------

class MemoryPairSource final : public FrameSource {
 public:
  MemoryPairSource(cv::Mat left, cv::Mat right, std::optional<StereoCalibration> calibration,
                   std::string description)
      : left_(std::move(left)),
        right_(std::move(right)),
        calibration_(std::move(calibration)),
        description_(std::move(description)) {}

  std::optional<StereoFrame> Read() override {
    StereoFrame frame{left_.clone(), right_.clone(), next_++, SecondsSince(start_)};
    return frame;
  }
  std::string Describe() const override { return description_; }
  std::optional<StereoCalibration> Calibration() const override { return calibration_; }

 private:
  cv::Mat left_, right_;
  std::optional<StereoCalibration> calibration_;
  std::string description_;
  int64_t next_ = 0;
  Clock::time_point start_ = Clock::now();
};

class ImageSequenceSource final : public FrameSource {
 public:
  ImageSequenceSource(std::vector<std::filesystem::path> left,
                      std::vector<std::filesystem::path> right, bool repeat, bool loop,
                      std::string description)
      : left_(std::move(left)),
        right_(std::move(right)),
        repeat_(repeat),
        loop_(loop),
        description_(std::move(description)) {
    if (left_.size() != right_.size()) {
      throw InputError(fmt::format("{}: {} left images but {} right images; they must pair up",
                                   description_, left_.size(), right_.size()));
    }
    // Read the first pair now, so that a bad file fails when the source is opened.
    first_ = Load(0);
  }

  std::optional<StereoFrame> Read() override {
    const size_t n = left_.size();
    if (next_ >= n && !repeat_ && !loop_) return std::nullopt;
    const size_t i = repeat_ ? 0 : next_ % n;
    StereoFrame frame = i == 0 && first_ ? *first_ : Load(i);
    if (repeat_) {  // one pair for ever: hand out copies so that callers may draw on them
      frame.left = frame.left.clone();
      frame.right = frame.right.clone();
    }
    frame.index = static_cast<int64_t>(next_++);
    frame.timestamp_s = SecondsSince(start_);
    return frame;
  }

  std::string Describe() const override { return description_; }

 private:
  // ReadImage(kColor) gives 8-bit BGR whatever the file holds.
  StereoFrame Load(size_t i) const {
    StereoFrame frame;
    frame.left = ReadImage(left_[i], ImageColor::kColor);
    frame.right = ReadImage(right_[i], ImageColor::kColor);
    CheckSameSize(frame.left, left_[i], frame.right, right_[i]);
    return frame;
  }

  std::vector<std::filesystem::path> left_, right_;
  bool repeat_, loop_;
  std::string description_;
  std::optional<StereoFrame> first_;
  size_t next_ = 0;
  Clock::time_point start_ = Clock::now();
};

// ---------------------------------------------------------------------------------------------
// Video files and cameras through cv::VideoCapture (in the OpenCV plugin: io/opencv_plugin.h).
// ---------------------------------------------------------------------------------------------

// OpenCV's backends print their own failures on stderr while probing a file; our error says it
// once, so they are silenced while a capture opens.
class QuietOpenCvLog {
 public:
  QuietOpenCvLog()
      : previous_(cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT)) {}
  ~QuietOpenCvLog() { cv::utils::logging::setLogLevel(previous_); }

 private:
  cv::utils::logging::LogLevel previous_;
};

std::unique_ptr<VideoCaptureHandle> OpenCapture(const std::string& name, bool is_device,
                                                const FrameSourceOptions& o,
                                                const std::string& spec) {
  const OpenCvPlugin& opencv = LoadOpenCvPlugin(fmt::format("source '{}'", spec));
  const QuietOpenCvLog quiet;
  std::unique_ptr<VideoCaptureHandle> capture;
  if (is_device) {
    // "/dev/video3" or "3"
    std::string digits = name;
    if (digits.rfind("/dev/video", 0) == 0) digits = digits.substr(10);
    const bool numeric = !digits.empty() && std::all_of(digits.begin(), digits.end(), [](char c) {
      return c >= '0' && c <= '9';
    });
    if (!numeric) {
      throw UsageError(
          fmt::format("source '{}': V4L2 device '{}' must be /dev/videoN or N", spec, name));
    }
    if (!std::filesystem::exists("/dev/video" + digits)) {
      throw InputError(fmt::format("source '{}': no such camera /dev/video{}", spec, digits));
    }
    capture = opencv.OpenCamera(std::stoi(digits), cv::CAP_V4L2);
    if (capture->IsOpened()) {
      if (o.width > 0) capture->Set(cv::CAP_PROP_FRAME_WIDTH, o.width);
      if (o.height > 0) capture->Set(cv::CAP_PROP_FRAME_HEIGHT, o.height);
      if (o.fps > 0) capture->Set(cv::CAP_PROP_FPS, o.fps);
    }
  } else {
    if (name.find("://") == std::string::npos && name.find('!') == std::string::npos &&
        !std::filesystem::exists(name)) {
      throw InputError(fmt::format("source '{}': video file '{}' does not exist", spec, name));
    }
    // FFmpeg for files and URLs, GStreamer for pipelines ("... ! appsink"). Not CAP_ANY: probing
    // every backend loads GStreamer's plugins (and libusb) for any file, slowly and leakily.
    capture = opencv.OpenVideo(
        name, name.find('!') != std::string::npos ? cv::CAP_GSTREAMER : cv::CAP_FFMPEG);
  }
  if (!capture->IsOpened()) {
    throw InputError(fmt::format("source '{}': OpenCV could not open {} '{}'", spec,
                                 is_device ? "camera" : "video", name));
  }
  return capture;
}

class CaptureSource final : public FrameSource {
 public:
  // One capture with side-by-side frames (right empty) or two captures.
  CaptureSource(std::vector<std::string> names, bool devices, const FrameSourceOptions& options,
                const std::string& spec)
      : names_(std::move(names)), devices_(devices), loop_(options.loop && !devices), spec_(spec) {
    for (const std::string& name : names_) {
      captures_.push_back(OpenCapture(name, devices_, options, spec));
    }
    // Grab the first frame now: a file that opens but holds no decodable frame fails here.
    first_ = Grab();
    if (!first_) {
      throw InputError(fmt::format("source '{}': no frame could be read", spec_));
    }
    // Fixed from here on (a frame of another size fails the ranging loop), so Describe() needs no
    // lock while the loop grabs.
    const std::string kind = devices_ ? "v4l2" : "video";
    const cv::Size size = first_->left.size();
    description_ = names_.size() == 1 ? fmt::format("{} {} (side by side, {}x{} per camera)", kind,
                                                    names_[0], size.width, size.height)
                                      : fmt::format("{} {} + {} ({}x{})", kind, names_[0],
                                                    names_[1], size.width, size.height);
  }

  std::optional<StereoFrame> Read() override {
    std::optional<StereoFrame> frame;
    if (first_) {
      frame = std::move(first_);
      first_.reset();
    } else {
      frame = Grab();
      if (!frame && !devices_) CheckNotTruncated();
      if (!frame && loop_ && next_ > 0) {
        for (auto& c : captures_) c->Set(cv::CAP_PROP_POS_FRAMES, 0);
        pass_frames_ = 0;
        frame = Grab();
      }
    }
    if (!frame) {
      if (devices_) {
        throw InputError(fmt::format("source '{}': the camera stopped delivering frames", spec_));
      }
      return std::nullopt;
    }
    ++pass_frames_;
    frame->index = next_++;
    frame->timestamp_s = SecondsSince(start_);
    return frame;
  }

  std::string Describe() const override { return description_; }

  bool IsLive() const override { return devices_; }

 private:
  // A video file that ends before the frame count its container announces is truncated or
  // damaged: an error naming the file, not a quiet end (a recording cut short by a full disk or
  // a dropped connection must not pass for a complete run).
  void CheckNotTruncated() {
    const size_t i = ended_;  // the file that delivered no frame
    const double announced = captures_[i]->Get(cv::CAP_PROP_FRAME_COUNT);
    if (announced > 0 && double(pass_frames_) + 1 < announced) {
      throw InputError(fmt::format(
          "source '{}': video '{}' ended after {} of the {} frames its header announces "
          "(truncated or damaged)",
          spec_, names_[i], pass_frames_, int64_t(announced)));
    }
  }

  std::optional<StereoFrame> Grab() {
    // grab() both first, then retrieve(): the two cameras' exposures are as close in time as
    // V4L2 allows without a hardware trigger.
    for (size_t i = 0; i < captures_.size(); ++i) {
      if (!captures_[i]->Grab()) {
        ended_ = i;
        return std::nullopt;
      }
    }
    std::vector<cv::Mat> images(captures_.size());
    for (size_t i = 0; i < captures_.size(); ++i) {
      if (!captures_[i]->Retrieve(&images[i]) || images[i].empty()) {
        ended_ = i;
        return std::nullopt;
      }
    }
    StereoFrame frame;
    if (images.size() == 1) {
      detail::SplitSideBySide(detail::ToBgr8(images[0], spec_), spec_, &frame.left, &frame.right);
    } else {
      frame.left = detail::ToBgr8(images[0], spec_);
      frame.right = detail::ToBgr8(images[1], spec_);
      CheckSameSize(frame.left, names_[0], frame.right, names_[1]);
    }
    return frame;
  }

  std::vector<std::string> names_;
  bool devices_;
  bool loop_;
  std::string spec_;
  std::vector<std::unique_ptr<VideoCaptureHandle>> captures_;
  std::optional<StereoFrame> first_;
  std::string description_;
  int64_t next_ = 0;
  int64_t pass_frames_ = 0;  // frames delivered since the files' start (this pass)
  size_t ended_ = 0;         // the capture that delivered no frame last
  Clock::time_point start_ = Clock::now();
};

// A side-by-side still image: delivered again for every frame.
class SideBySideImageSource final : public FrameSource {
 public:
  SideBySideImageSource(const std::string& path, const std::string& spec) : path_(path) {
    detail::SplitSideBySide(ReadImage(path, ImageColor::kColor), fmt::format("source '{}'", spec),
                            &left_, &right_);
  }
  std::optional<StereoFrame> Read() override {
    StereoFrame frame{left_.clone(), right_.clone(), next_++, SecondsSince(start_)};
    return frame;
  }
  std::string Describe() const override {
    return fmt::format("side-by-side image {} ({}x{} per camera)", path_, left_.cols, left_.rows);
  }

 private:
  std::string path_;
  cv::Mat left_, right_;
  int64_t next_ = 0;
  Clock::time_point start_ = Clock::now();
};

// ---------------------------------------------------------------------------------------------
// The synthetic power-line scene.
// ---------------------------------------------------------------------------------------------

class SyntheticSource final : public FrameSource {
 public:
  SyntheticSource(uint64_t seed, const FrameSourceOptions& options)
      : seed_(seed),
        scene_(MakeOptions(seed, options)),
        renderer_(scene_),
        calibration_(sim::MakeStereoCalibration(scene_.rig)) {}

  std::optional<StereoFrame> Read() override {
    // Fresh sensor noise per frame, deterministic in (seed, frame index).
    const sim::PowerLineScene scene = renderer_.Capture(renderer_.DefaultNoiseSeed() + next_);
    StereoFrame frame{scene.left, scene.right, next_++, SecondsSince(start_)};
    return frame;
  }
  std::string Describe() const override {
    return fmt::format("synthetic power-line scene (seed {})", seed_);
  }
  std::optional<StereoCalibration> Calibration() const override { return calibration_; }

 private:
  static sim::PowerLineSceneOptions MakeOptions(uint64_t seed, const FrameSourceOptions& o) {
    sim::PowerLineSceneOptions scene;
    scene.seed = seed;
    scene.sensor.supersampling = o.synthetic_supersampling;
    if (!o.synthetic_obstacles.empty()) {
      scene.obstacles = sim::ParseObstacleSpecs(o.synthetic_obstacles);
    }
    return scene;
  }

  uint64_t seed_;
  sim::PowerLineSceneOptions scene_;
  sim::PowerLineSceneRenderer renderer_;
  StereoCalibration calibration_;  // the scene's true calibration (what every capture carries)
  int64_t next_ = 0;
  Clock::time_point start_ = Clock::now();
};

// The moving synthetic sequence: the robot rides toward the obstacles on its line. Frame k carries
// the sequence's timestamp k / fps (robot time, so approach rates are true however fast the
// frames are processed); the next frame renders in the background while the caller works on this
// one. With `loop` the sequence starts again at its end, the timestamps running on.
class SyntheticSequenceSource final : public FrameSource {
 public:
  SyntheticSequenceSource(uint64_t seed, const FrameSourceOptions& options)
      : seed_(seed),
        loop_(options.loop),
        sequence_(MakeOptions(seed, options)),
        calibration_(sim::MakeStereoCalibration(sequence_.options().scene.rig)) {
    Prefetch(0);
  }
  ~SyntheticSequenceSource() override {
    if (next_.valid()) next_.wait();
  }

  std::optional<StereoFrame> Read() override {
    if (!next_.valid()) return std::nullopt;
    sim::PowerLineScene scene = next_.get();
    const int64_t index = served_++;
    const int64_t following = served_;
    if (loop_ || following < sequence_.size()) Prefetch(following);
    return StereoFrame{std::move(scene.left), std::move(scene.right), index,
                       static_cast<double>(index) / sequence_.options().fps};
  }
  std::string Describe() const override {
    return fmt::format(
        "synthetic power-line sequence (seed {}, {} frames at {} Hz, {} m/s toward {} obstacles{})",
        seed_, sequence_.size(), sequence_.options().fps, sequence_.options().speed_mps,
        sequence_.layout().size(), loop_ ? ", looping" : "");
  }
  std::optional<StereoCalibration> Calibration() const override { return calibration_; }

 private:
  static sim::PowerLineSequenceOptions MakeOptions(uint64_t seed, const FrameSourceOptions& o) {
    sim::PowerLineSequenceOptions sequence;
    sequence.seed = seed;
    sequence.speed_mps = o.synthetic_speed_mps;
    sequence.start_gap_m = o.synthetic_start_m;
    sequence.scene.sensor.supersampling = o.synthetic_supersampling;
    sequence.Check();
    return sequence;
  }
  void Prefetch(int64_t index) {
    const int frame = static_cast<int>(index % sequence_.size());
    next_ = std::async(std::launch::async, [this, frame] { return sequence_.Render(frame); });
  }

  uint64_t seed_;
  bool loop_;
  sim::PowerLineSequence sequence_;
  StereoCalibration calibration_;  // the sequence's true calibration
  std::future<sim::PowerLineScene> next_;
  int64_t served_ = 0;
};

bool IsVideoFile(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  static const std::vector<std::string> kImage = {".png",  ".jpg", ".jpeg", ".bmp", ".tif",
                                                  ".tiff", ".pgm", ".ppm",  ".pnm", ".webp"};
  return std::find(kImage.begin(), kImage.end(), ext) == kImage.end();
}

}  // namespace

void FrameSourceOptions::Check() const {
  CheckOption(width >= 0, "FrameSourceOptions.width", width, "must be >= 0 (0 = device default)");
  CheckOption(height >= 0, "FrameSourceOptions.height", height,
              "must be >= 0 (0 = device default)");
  CheckOption(fps >= 0, "FrameSourceOptions.fps", fps, "must be >= 0 (0 = device default)");
  CheckOption(synthetic_supersampling >= 1 && synthetic_supersampling <= 8,
              "FrameSourceOptions.synthetic_supersampling", synthetic_supersampling,
              "must be in 1..8");
  CheckOption(synthetic_speed_mps == 0 || (synthetic_speed_mps >= 0.02 && synthetic_speed_mps <= 3),
              "FrameSourceOptions.synthetic_speed_mps", synthetic_speed_mps,
              "must be 0 (the still scene) or in [0.02, 3] m/s");
}

std::vector<std::string> FrameSourceSchemes() {
  return {"synthetic[:SEED]", "pair:LEFT,RIGHT", "images:LEFT_GLOB,RIGHT_GLOB",
          "video:LEFT,RIGHT", "sbs:FILE",        "v4l2:DEVICE[,DEVICE]"};
}

std::unique_ptr<FrameSource> OpenFrameSource(const std::string& spec,
                                             const FrameSourceOptions& options) {
  options.Check();
  const size_t colon = spec.find(':');
  const std::string scheme = spec.substr(0, colon);
  const std::string body = colon == std::string::npos ? "" : spec.substr(colon + 1);
  if (scheme == "synthetic") {
    uint64_t seed = 1;
    if (!body.empty()) {
      size_t used = 0;
      try {
        seed = std::stoull(body, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used != body.size()) {
        throw UsageError(
            fmt::format("source '{}': the seed '{}' must be a non-negative integer", spec, body));
      }
    }
    if (options.synthetic_obstacles.empty() && options.synthetic_speed_mps > 0) {
      return std::make_unique<SyntheticSequenceSource>(seed, options);
    }
    return std::make_unique<SyntheticSource>(seed, options);
  }
  if (colon == std::string::npos) {
    throw UsageError(fmt::format("source '{}': expected SCHEME:..., one of {}", spec,
                                 fmt::join(FrameSourceSchemes(), ", ")));
  }
  if (scheme == "pair") {
    const auto parts = SplitParts(spec, body, 2);
    return std::make_unique<ImageSequenceSource>(
        std::vector<std::filesystem::path>{parts[0]}, std::vector<std::filesystem::path>{parts[1]},
        /*repeat=*/true, /*loop=*/false, fmt::format("image pair {} + {}", parts[0], parts[1]));
  }
  if (scheme == "images") {
    const auto parts = SplitParts(spec, body, 2);
    auto left = ExpandGlob(parts[0]);  // InputError naming the pattern when nothing matches
    auto right = ExpandGlob(parts[1]);
    const std::string description =
        fmt::format("image sequence {} + {} ({} pairs)", parts[0], parts[1], left.size());
    return std::make_unique<ImageSequenceSource>(std::move(left), std::move(right),
                                                 /*repeat=*/false, options.loop, description);
  }
  if (scheme == "video") {
    return std::make_unique<CaptureSource>(SplitParts(spec, body, 2), /*devices=*/false, options,
                                           spec);
  }
  if (scheme == "sbs") {
    const auto parts = SplitParts(spec, body, 1);
    if (!IsVideoFile(parts[0])) return std::make_unique<SideBySideImageSource>(parts[0], spec);
    return std::make_unique<CaptureSource>(parts, /*devices=*/false, options, spec);
  }
  if (scheme == "v4l2") {
    return std::make_unique<CaptureSource>(SplitParts(spec, body, 0), /*devices=*/true, options,
                                           spec);
  }
  throw UsageError(fmt::format("source '{}': unknown scheme '{}', expected one of {}", spec, scheme,
                               fmt::join(FrameSourceSchemes(), ", ")));
}

namespace detail {

void SplitSideBySide(const cv::Mat& frame, const std::string& what, cv::Mat* left, cv::Mat* right) {
  if (frame.empty()) throw InputError(fmt::format("{}: empty side-by-side frame", what));
  if (frame.cols % 2 != 0) {
    throw InputError(fmt::format(
        "{}: a side-by-side frame must have an even width (left half | right half), got {}x{}",
        what, frame.cols, frame.rows));
  }
  const int half = frame.cols / 2;
  *left = frame.colRange(0, half).clone();
  *right = frame.colRange(half, frame.cols).clone();
}

cv::Mat ToBgr8(const cv::Mat& image, const std::string& what) {
  if (image.empty()) throw InputError(fmt::format("{}: empty image", what));
  if (image.depth() != CV_8U) {
    throw InputError(
        fmt::format("{}: expected 8-bit images, got OpenCV depth {}", what, image.depth()));
  }
  cv::Mat bgr;
  switch (image.channels()) {
    case 1:
      cv::cvtColor(image, bgr, cv::COLOR_GRAY2BGR);
      return bgr;
    case 3:
      return image;
    case 4:
      cv::cvtColor(image, bgr, cv::COLOR_BGRA2BGR);
      return bgr;
    default:
      throw InputError(
          fmt::format("{}: expected 1, 3 or 4 channels, got {}", what, image.channels()));
  }
}

}  // namespace detail
std::unique_ptr<FrameSource> RepeatedPairSource(const cv::Mat& left, const cv::Mat& right,
                                                std::optional<StereoCalibration> calibration,
                                                const std::string& description) {
  cv::Mat l = detail::ToBgr8(left, description + " (left)");
  cv::Mat r = detail::ToBgr8(right, description + " (right)");
  if (l.size() != r.size()) {
    throw InputError(fmt::format("{}: the left image is {}x{} but the right is {}x{}", description,
                                 l.cols, l.rows, r.cols, r.rows));
  }
  return std::make_unique<MemoryPairSource>(l, r, std::move(calibration), description);
}

}  // namespace linesight
