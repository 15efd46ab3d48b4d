// linesight_opencv_plugin.so: the OpenCV modules that are slow to load, behind the OpenCvPlugin
// interface (io/opencv_plugin.h). Links OpenCV only; nothing of linesight's libraries.
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>
#include <opencv2/ximgproc/disparity_filter.hpp>

#include "linesight/io/opencv_plugin.h"

namespace linesight {
namespace {

class VideoCapture final : public VideoCaptureHandle {
 public:
  VideoCapture(const std::string& name, int api) : capture_(name, api) {}
  VideoCapture(int index, int api) : capture_(index, api) {}
  bool IsOpened() const override { return capture_.isOpened(); }
  bool Grab() override { return capture_.grab(); }
  bool Retrieve(cv::Mat* image) override { return capture_.retrieve(*image); }
  bool Set(int property, double value) override { return capture_.set(property, value); }
  double Get(int property) const override { return capture_.get(property); }

 private:
  cv::VideoCapture capture_;
};

class SgbmWls final : public SgbmWlsHandle {
 public:
  SgbmWls(const cv::Ptr<cv::StereoSGBM>& sgbm, double lambda, double sigma)
      : sgbm_(sgbm),
        right_matcher_(cv::ximgproc::createRightMatcher(sgbm)),
        wls_(cv::ximgproc::createDisparityWLSFilter(sgbm)) {
    wls_->setLambda(lambda);
    wls_->setSigmaColor(sigma);
  }

  void Compute(const cv::Mat& left_gray, const cv::Mat& right_gray, const cv::Mat& left,
               const cv::Mat& right, cv::Mat* filtered) override {
    cv::Mat left_fixed, right_fixed;
    sgbm_->compute(left_gray, right_gray, left_fixed);
    right_matcher_->compute(right_gray, left_gray, right_fixed);
    wls_->filter(left_fixed, left, *filtered, right_fixed, cv::Rect(), right);
  }

 private:
  cv::Ptr<cv::StereoSGBM> sgbm_;
  cv::Ptr<cv::StereoMatcher> right_matcher_;
  cv::Ptr<cv::ximgproc::DisparityWLSFilter> wls_;
};

class Plugin final : public OpenCvPlugin {
 public:
  cv::Mat Decode(const cv::Mat& buffer, int flags) const override {
    return cv::imdecode(buffer, flags);
  }
  bool Write(const std::string& path, const cv::Mat& image) const override {
    return cv::imwrite(path, image);
  }
  bool Encode(const std::string& extension, const cv::Mat& image, const std::vector<int>& params,
              std::vector<uchar>* bytes) const override {
    return cv::imencode(extension, image, *bytes, params);
  }
  std::unique_ptr<VideoCaptureHandle> OpenVideo(const std::string& name, int api) const override {
    return std::make_unique<VideoCapture>(name, api);
  }
  std::unique_ptr<VideoCaptureHandle> OpenCamera(int index, int api) const override {
    return std::make_unique<VideoCapture>(index, api);
  }
  std::unique_ptr<SgbmWlsHandle> CreateSgbmWls(const cv::Ptr<cv::StereoSGBM>& sgbm, double lambda,
                                               double sigma) const override {
    return std::make_unique<SgbmWls>(sgbm, lambda, sigma);
  }
};

}  // namespace
}  // namespace linesight

extern "C" __attribute__((visibility("default"))) const linesight::OpenCvPlugin*
linesight_opencv_plugin(int* abi) {
  static const linesight::Plugin plugin;
  *abi = linesight::kOpenCvPluginAbi;
  return &plugin;
}
