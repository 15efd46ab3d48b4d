#include "linesight/rectify/rectifier.h"

#include <fmt/format.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "linesight/core/error.h"

namespace linesight {
namespace {

void CheckMatrix(const cv::Mat& m, int rows, int cols, const char* name) {
  if (m.empty()) throw InputError(fmt::format("calibration: matrix {} is missing", name));
  if (m.rows != rows || m.cols != cols) {
    throw InputError(fmt::format("calibration: matrix {} must be {}x{}, got {}x{}", name, rows,
                                 cols, m.rows, m.cols));
  }
}

void CheckIntrinsicsAndExtrinsics(const StereoCalibration& calib) {
  if (calib.image_size.width <= 0 || calib.image_size.height <= 0) {
    throw InputError(fmt::format("calibration: image size {}x{} is not positive",
                                 calib.image_size.width, calib.image_size.height));
  }
  CheckMatrix(calib.M1, 3, 3, "M1");
  CheckMatrix(calib.M2, 3, 3, "M2");
  CheckMatrix(calib.R, 3, 3, "R");
  if (calib.T.total() != 3) throw InputError("calibration: matrix T must have 3 elements");
}

bool HasStoredRectification(const StereoCalibration& calib) {
  return !calib.R1.empty() && !calib.R2.empty() && !calib.P1.empty() && !calib.P2.empty() &&
         !calib.Q.empty();
}

// Largest rectangle (greedy shrinking) inside which every rectified pixel maps into the raw image.
cv::Rect ValidRectangle(const cv::Mat& map_x, const cv::Mat& map_y, cv::Size raw_size) {
  cv::Mat valid(map_x.size(), CV_8U);
  for (int y = 0; y < map_x.rows; ++y) {
    const float* mx = map_x.ptr<float>(y);
    const float* my = map_y.ptr<float>(y);
    uchar* v = valid.ptr<uchar>(y);
    for (int x = 0; x < map_x.cols; ++x) {
      v[x] = mx[x] >= 0.0f && my[x] >= 0.0f && mx[x] <= raw_size.width - 1.0f &&
             my[x] <= raw_size.height - 1.0f;
    }
  }
  int left = 0, top = 0, right = valid.cols - 1, bottom = valid.rows - 1;
  while (left <= right && top <= bottom) {
    auto invalid_in_row = [&](int y) {
      int n = 0;
      for (int x = left; x <= right; ++x) n += !valid.at<uchar>(y, x);
      return n;
    };
    auto invalid_in_col = [&](int x) {
      int n = 0;
      for (int y = top; y <= bottom; ++y) n += !valid.at<uchar>(y, x);
      return n;
    };
    // Shrink the side with the largest share of invalid pixels.
    const double t = invalid_in_row(top) / double(right - left + 1);
    const double b = invalid_in_row(bottom) / double(right - left + 1);
    const double l = invalid_in_col(left) / double(bottom - top + 1);
    const double r = invalid_in_col(right) / double(bottom - top + 1);
    const double worst = std::max({t, b, l, r});
    if (worst == 0.0) return cv::Rect(left, top, right - left + 1, bottom - top + 1);
    if (worst == t) {
      ++top;
    } else if (worst == b) {
      --bottom;
    } else if (worst == l) {
      ++left;
    } else {
      --right;
    }
  }
  return {};
}

}  // namespace

void RectifyOptions::Check() const {
  CheckOption(alpha == -1.0 || (alpha >= 0.0 && alpha <= 1.0), "RectifyOptions.alpha", alpha,
              "must be -1 (OpenCV default) or in [0, 1]");
  CheckOption(
      interpolation == cv::INTER_NEAREST || interpolation == cv::INTER_LINEAR ||
          interpolation == cv::INTER_CUBIC || interpolation == cv::INTER_LANCZOS4,
      "RectifyOptions.interpolation", interpolation,
      "must be cv::INTER_NEAREST (0), INTER_LINEAR (1), INTER_CUBIC (2) or INTER_LANCZOS4 (4)");
}

Rectification ComputeRectification(const StereoCalibration& calib, const RectifyOptions& options) {
  options.Check();
  CheckIntrinsicsAndExtrinsics(calib);
  Rectification out;
  out.calibration = calib;
  StereoCalibration& c = out.calibration;
  // cv::Mat copies share data: give the outputs fresh buffers so that the caller's matrices stay
  // intact.
  c.R1 = cv::Mat();
  c.R2 = cv::Mat();
  c.P1 = cv::Mat();
  c.P2 = cv::Mat();
  c.Q = cv::Mat();
  cv::Mat D1 = calib.D1.empty() ? cv::Mat::zeros(1, 5, CV_64F) : calib.D1;
  cv::Mat D2 = calib.D2.empty() ? cv::Mat::zeros(1, 5, CV_64F) : calib.D2;
  cv::Mat T = calib.T.reshape(1, 3);
  cv::stereoRectify(calib.M1, D1, calib.M2, D2, calib.image_size, calib.R, T, c.R1, c.R2, c.P1,
                    c.P2, c.Q, options.zero_disparity ? cv::CALIB_ZERO_DISPARITY : 0, options.alpha,
                    calib.image_size, &out.valid_roi_left, &out.valid_roi_right);
  return out;
}

Rectifier::Rectifier(const StereoCalibration& calib, const RectifyOptions& options)
    : options_(options) {
  options_.Check();
  CheckIntrinsicsAndExtrinsics(calib);
  const bool recompute = options_.recompute || !HasStoredRectification(calib);
  if (recompute) {
    rectification_ = ComputeRectification(calib, options_);
  } else {
    CheckMatrix(calib.R1, 3, 3, "R1");
    CheckMatrix(calib.R2, 3, 3, "R2");
    CheckMatrix(calib.P1, 3, 4, "P1");
    CheckMatrix(calib.P2, 3, 4, "P2");
    CheckMatrix(calib.Q, 4, 4, "Q");
    rectification_.calibration = calib;
  }
  const StereoCalibration& c = rectification_.calibration;
  cv::initUndistortRectifyMap(c.M1, c.D1, c.R1, c.P1, c.image_size, CV_32FC1, left_map_x_,
                              left_map_y_);
  cv::initUndistortRectifyMap(c.M2, c.D2, c.R2, c.P2, c.image_size, CV_32FC1, right_map_x_,
                              right_map_y_);
  if (!recompute) {
    rectification_.valid_roi_left = ValidRectangle(left_map_x_, left_map_y_, c.image_size);
    rectification_.valid_roi_right = ValidRectangle(right_map_x_, right_map_y_, c.image_size);
  }
}

cv::Mat Rectifier::Remap(const cv::Mat& image, const cv::Mat& map_x, const cv::Mat& map_y,
                         const char* which) const {
  const cv::Size expected = rectification_.calibration.image_size;
  if (image.empty()) throw InputError(fmt::format("{} image is empty", which));
  if (image.size() != expected) {
    throw InputError(fmt::format("{} image is {}x{} but the calibration is for {}x{}", which,
                                 image.cols, image.rows, expected.width, expected.height));
  }
  cv::Mat out;
  cv::remap(image, out, map_x, map_y, options_.interpolation, cv::BORDER_CONSTANT,
            cv::Scalar::all(0));
  return out;
}

void Rectifier::Rectify(const cv::Mat& left, const cv::Mat& right, cv::Mat* left_rectified,
                        cv::Mat* right_rectified) const {
  LS_CHECK(left_rectified != nullptr && right_rectified != nullptr);
  *left_rectified = RectifyLeft(left);
  *right_rectified = RectifyRight(right);
}

cv::Mat Rectifier::RectifyLeft(const cv::Mat& left) const {
  return Remap(left, left_map_x_, left_map_y_, "left");
}

cv::Mat Rectifier::RectifyRight(const cv::Mat& right) const {
  return Remap(right, right_map_x_, right_map_y_, "right");
}

std::vector<cv::Point2f> Rectifier::RectifyLeftPoints(const std::vector<cv::Point2f>& raw) const {
  const StereoCalibration& c = rectification_.calibration;
  std::vector<cv::Point2f> out;
  if (raw.empty()) return out;
  cv::undistortPoints(raw, out, c.M1, c.D1, c.R1, c.P1);
  return out;
}

std::vector<cv::Point2f> Rectifier::RectifyRightPoints(const std::vector<cv::Point2f>& raw) const {
  const StereoCalibration& c = rectification_.calibration;
  std::vector<cv::Point2f> out;
  if (raw.empty()) return out;
  cv::undistortPoints(raw, out, c.M2, c.D2, c.R2, c.P2);
  return out;
}

cv::Mat DrawEpipolarCheck(const cv::Mat& left_rectified, const cv::Mat& right_rectified,
                          int spacing) {
  LS_CHECK(spacing > 0);
  auto to_bgr = [](const cv::Mat& image) {
    cv::Mat bgr;
    if (image.channels() == 1) {
      cv::Mat eight;
      image.convertTo(eight, CV_8U);
      cv::cvtColor(eight, bgr, cv::COLOR_GRAY2BGR);
    } else {
      image.convertTo(bgr, CV_8U);
    }
    return bgr;
  };
  cv::Mat left = to_bgr(left_rectified), right = to_bgr(right_rectified);
  cv::Mat canvas(std::max(left.rows, right.rows), left.cols + right.cols, CV_8UC3,
                 cv::Scalar::all(0));
  left.copyTo(canvas(cv::Rect(0, 0, left.cols, left.rows)));
  right.copyTo(canvas(cv::Rect(left.cols, 0, right.cols, right.rows)));
  int index = 0;
  for (int y = spacing / 2; y < canvas.rows; y += spacing, ++index) {
    const cv::Scalar colour = index % 2 ? cv::Scalar(0, 255, 0) : cv::Scalar(0, 0, 255);
    cv::line(canvas, {0, y}, {canvas.cols - 1, y}, colour, 1, cv::LINE_8);
  }
  return canvas;
}

}  // namespace linesight
