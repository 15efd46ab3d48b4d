// Acquisition: where stereo pairs come from. One interface over image pairs, image sequences,
// side-by-side or two-file video, V4L2 cameras and the synthetic power-line scene, chosen by a
// source string (the `--source` of `linesight serve` and `linesight acquire`):
//
//   synthetic[:SEED]            the embedded power-line scene (sim/) with its true calibration:
//                               the robot riding its line toward the obstacles of the seed
//                               (sim/power_line_sequence.h, timestamps in robot time); with
//                               synthetic_obstacles or speed 0 the still scene, captured again with
//                               fresh sensor noise for every frame
//   pair:LEFT,RIGHT             one image pair, delivered again for every frame
//   images:LEFT_GLOB,RIGHT_GLOB image sequences, paired in sorted order (equal counts)
//   video:LEFT,RIGHT            two video files (or GStreamer / URL strings OpenCV opens)
//   sbs:FILE                    one side-by-side video or image: left half | right half
//   v4l2:DEVICE                 one V4L2 camera that delivers side-by-side frames (most USB stereo
//                               heads, e.g. the MYNT S1030 or ZED in UVC mode)
//   v4l2:DEVICE,DEVICE          two V4L2 cameras (left, right); DEVICE = /dev/videoN or N
//
// Every frame is a left/right pair of 8-bit BGR images of the same size. Bad sources (unknown
// scheme, missing file, a device that does not open, mismatched sizes, an odd side-by-side width)
// throw InputError naming the source and what was expected.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "linesight/io/stereo_calibration.h"

namespace linesight {

struct StereoFrame {
  cv::Mat left, right;     // CV_8UC3 BGR, same size
  int64_t index = 0;       // 0-based frame number from this source
  double timestamp_s = 0;  // seconds since the source was opened (capture time)
};

struct FrameSourceOptions {
  // Requested capture size and rate for V4L2 cameras (0 = the device's default). For a
  // side-by-side camera the width is that of the whole frame (both halves).
  int width = 0;
  int height = 0;
  double fps = 0;
  // Sequences, videos and the synthetic sequence start again from the first frame at their end
  // instead of ending.
  bool loop = false;
  // Synthetic source: the robot's speed along the line (m/s; 0 = the still scene), the still
  // scene's obstacles ("damper:1.5,clamp:3,insulator:4.5" like `linesight render`; empty = the
  // moving sequence, or the still scene's defaults at speed 0) and supersampling (1 = fastest:
  // about 0.3 s per 752x480 frame on 2 cores, rendered while the previous frame is processed).
  double synthetic_speed_mps = 0.3;
  double synthetic_start_m = 6.0;  // moving sequence: arc to the first obstacle at the first frame
  std::string synthetic_obstacles;
  int synthetic_supersampling = 1;

  void Check() const;
};

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  // The next pair, or std::nullopt when the source has ended (a finished sequence or video without
  // loop; a live camera never ends but may throw InputError when it stops delivering).
  virtual std::optional<StereoFrame> Read() = 0;
  // e.g. "v4l2 /dev/video0 (side by side, 1504x480)".
  virtual std::string Describe() const = 0;
  // True for cameras (frames arrive at the camera's rate and are never repeated).
  virtual bool IsLive() const { return false; }
  // A calibration that comes with the source (the synthetic scene's true one), if any.
  virtual std::optional<StereoCalibration> Calibration() const { return std::nullopt; }
};

// Opens a source from its string (grammar at the top of the file). Throws UsageError for a string
// that does not parse (unknown scheme, missing part) and InputError for one that does not open.
std::unique_ptr<FrameSource> OpenFrameSource(const std::string& spec,
                                             const FrameSourceOptions& options = {});

// One pair held in memory, delivered again (as copies) for every frame with wall-clock timestamps,
// with the calibration it comes with: the live loop's benchmark and tests. Throws InputError when
// the images differ in size or are not 8-bit grey or BGR.
std::unique_ptr<FrameSource> RepeatedPairSource(const cv::Mat& left, const cv::Mat& right,
                                                std::optional<StereoCalibration> calibration,
                                                const std::string& description);

// The schemes OpenFrameSource understands, for help texts.
std::vector<std::string> FrameSourceSchemes();

namespace detail {

// Splits one side-by-side frame into its halves (copies). Throws InputError naming `what` when the
// width is odd or the frame is empty.
void SplitSideBySide(const cv::Mat& frame, const std::string& what, cv::Mat* left, cv::Mat* right);
// 8-bit BGR of any 8-bit grey / BGR / BGRA image; InputError naming `what` otherwise.
cv::Mat ToBgr8(const cv::Mat& image, const std::string& what);

}  // namespace detail
}  // namespace linesight
