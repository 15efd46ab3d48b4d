// The OpenCV modules that only some commands need, loaded when first used.
//
// Debian's libopencv_imgcodecs pulls in GDAL and ~120 shared libraries, libopencv_videoio ~240
// (FFmpeg, GStreamer) and libopencv_ximgproc needs imgcodecs: linked into the `linesight` binary,
// loading them costs every process ~200 ms before main(), `linesight --help` included. They are
// linked into a plugin instead (linesight_opencv_plugin.so, built from opencv_plugin_impl.cc),
// which LoadOpenCvPlugin() opens with dlopen the first time a command reads an image format other
// than PNG, JPEG and PFM, writes one, opens a video file or camera, or runs the sgbm-wls matcher.
#pragma once

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

namespace linesight {

// cv::VideoCapture's calls used by the frame sources.
class VideoCaptureHandle {
 public:
  virtual ~VideoCaptureHandle() = default;
  virtual bool IsOpened() const = 0;
  virtual bool Grab() = 0;
  virtual bool Retrieve(cv::Mat* image) = 0;
  virtual bool Set(int property, double value) = 0;
  virtual double Get(int property) const = 0;
};

// SGBM followed by ximgproc's DisparityWLSFilter guided by the left image.
class SgbmWlsHandle {
 public:
  virtual ~SgbmWlsHandle() = default;
  // Left and right 16×fixed-point disparities of the matcher, then the filtered left map.
  virtual void Compute(const cv::Mat& left_gray, const cv::Mat& right_gray, const cv::Mat& left,
                       const cv::Mat& right, cv::Mat* filtered) = 0;
};

class OpenCvPlugin {
 public:
  virtual ~OpenCvPlugin() = default;
  // cv::imdecode, cv::imwrite, cv::imencode (they throw cv::Exception as OpenCV does).
  virtual cv::Mat Decode(const cv::Mat& buffer, int flags) const = 0;
  virtual bool Write(const std::string& path, const cv::Mat& image) const = 0;
  virtual bool Encode(const std::string& extension, const cv::Mat& image,
                      const std::vector<int>& params, std::vector<uchar>* bytes) const = 0;
  // cv::VideoCapture(name, api) and cv::VideoCapture(index, api).
  virtual std::unique_ptr<VideoCaptureHandle> OpenVideo(const std::string& name, int api) const = 0;
  virtual std::unique_ptr<VideoCaptureHandle> OpenCamera(int index, int api) const = 0;
  virtual std::unique_ptr<SgbmWlsHandle> CreateSgbmWls(const cv::Ptr<cv::StereoSGBM>& sgbm,
                                                       double lambda, double sigma) const = 0;
};

// Changes whenever OpenCvPlugin's layout does: a plugin of another version is not used.
inline constexpr int kOpenCvPluginAbi = 1;

// The plugin, opened on first use (thread-safe). Looked for in $LINESIGHT_PLUGIN_DIR, beside the
// running program's ../lib/linesight, the installed library folder and the build tree. Throws
// Error naming `needed_for` and the folders searched when no usable plugin is found.
const OpenCvPlugin& LoadOpenCvPlugin(std::string_view needed_for);

}  // namespace linesight

// The plugin's one exported symbol.
extern "C" {
using LinesightOpenCvPluginEntry = const linesight::OpenCvPlugin* (*)(int* abi);
}
