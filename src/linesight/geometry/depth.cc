#include "linesight/geometry/depth.h"

#include <cmath>

#include <fmt/format.h>

#include "linesight/core/atomic_file.h"
#include "linesight/core/disparity.h"
#include "linesight/core/error.h"
#include "linesight/io/image_io.h"

namespace linesight {

StereoGeometry GeometryFromCalibration(const StereoCalibration& calib) {
  if (calib.Q.empty()) throw InputError("calibration: matrix Q is missing");
  if (calib.Q.rows != 4 || calib.Q.cols != 4) {
    throw InputError(
        fmt::format("calibration: matrix Q must be 4x4, got {}x{}", calib.Q.rows, calib.Q.cols));
  }
  cv::Mat q;
  calib.Q.convertTo(q, CV_64F);
  for (int i = 0; i < 16; ++i) {
    if (!std::isfinite(q.at<double>(i / 4, i % 4))) {
      throw InputError(fmt::format("calibration: Q({},{}) is not finite", i / 4, i % 4));
    }
  }
  StereoGeometry g;
  g.focal_px = q.at<double>(2, 3);
  const double inverse_baseline = q.at<double>(3, 2);
  if (!(g.focal_px > 0.0) || !(inverse_baseline > 0.0)) {
    throw InputError(
        fmt::format("calibration: Q gives focal length {} px and inverse baseline {} 1/m; both "
                    "must be positive "
                    "(a horizontal rig with the right camera at +x)",
                    g.focal_px, inverse_baseline));
  }
  g.baseline_m = 1.0 / inverse_baseline;
  g.disparity_offset_px = q.at<double>(3, 3) / inverse_baseline;
  g.cx = -q.at<double>(0, 3);
  g.cy = -q.at<double>(1, 3);
  return g;
}

void CheckDisparityMap(const cv::Mat& disparity, const std::string& name) {
  if (disparity.empty()) throw InputError(fmt::format("{}: disparity map is empty", name));
  if (disparity.type() != CV_32FC1) {
    throw InputError(fmt::format("{}: disparity map must be one float channel", name));
  }
  for (int y = 0; y < disparity.rows; ++y) {
    const float* row = disparity.ptr<float>(y);
    for (int x = 0; x < disparity.cols; ++x) {
      if (std::isnan(row[x]) || row[x] == -std::numeric_limits<float>::infinity()) {
        throw InputError(
            fmt::format("{}: pixel ({}, {}) holds {}; a disparity must be a finite number or +inf "
                        "(no estimate)",
                        name, x, y, row[x]));
      }
    }
  }
}

cv::Mat DepthFromDisparity(const cv::Mat& disparity, const StereoGeometry& geometry) {
  LS_CHECK(disparity.type() == CV_32FC1);
  cv::Mat depth(disparity.size(), CV_32FC1);
  const double fb = geometry.focal_px * geometry.baseline_m;
  for (int y = 0; y < disparity.rows; ++y) {
    const float* d = disparity.ptr<float>(y);
    float* z = depth.ptr<float>(y);
    for (int x = 0; x < disparity.cols; ++x) {
      const double shifted = double(d[x]) + geometry.disparity_offset_px;
      z[x] = IsValidDisparity(d[x]) && shifted > 0.0 ? float(fb / shifted) : kNoDepth;
    }
  }
  return depth;
}

cv::Mat PointsFromDisparity(const cv::Mat& disparity, const cv::Mat& Q) {
  LS_CHECK(disparity.type() == CV_32FC1);
  LS_CHECK(Q.rows == 4 && Q.cols == 4);
  cv::Matx44d q;
  Q.convertTo(cv::Mat(4, 4, CV_64F, q.val), CV_64F);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  cv::Mat points(disparity.size(), CV_32FC3);
  for (int y = 0; y < disparity.rows; ++y) {
    const float* d = disparity.ptr<float>(y);
    cv::Vec3f* p = points.ptr<cv::Vec3f>(y);
    for (int x = 0; x < disparity.cols; ++x) {
      const cv::Vec4d h = q * cv::Vec4d(x, y, d[x], 1.0);
      if (!IsValidDisparity(d[x]) || !(h[3] > 0.0)) {
        p[x] = cv::Vec3f(nan, nan, nan);
      } else {
        p[x] = cv::Vec3f(float(h[0] / h[3]), float(h[1] / h[3]), float(h[2] / h[3]));
      }
    }
  }
  return points;
}

void WriteDepthPng16(const std::filesystem::path& path, const cv::Mat& depth_m) {
  LS_CHECK(depth_m.type() == CV_32FC1);
  cv::Mat png(depth_m.size(), CV_16UC1);
  for (int y = 0; y < depth_m.rows; ++y) {
    const float* z = depth_m.ptr<float>(y);
    uint16_t* v = png.ptr<uint16_t>(y);
    for (int x = 0; x < depth_m.cols; ++x) {
      const double units = std::round(double(z[x]) * kDepthPngUnitsPerMetre);
      v[x] = std::isfinite(units) && units >= 1.0 && units <= 65535.0 ? uint16_t(units) : 0;
    }
  }
  WriteImage(path, png);
}

cv::Mat ReadDepthPng16(const std::filesystem::path& path) {
  const cv::Mat png = ReadImage(path, ImageColor::kUnchanged);
  if (png.type() != CV_16UC1) {
    throw InputError(fmt::format("{}: a depth PNG must be 16-bit single channel", path.string()));
  }
  cv::Mat depth;
  png.convertTo(depth, CV_32F, 1.0 / kDepthPngUnitsPerMetre);
  return depth;
}

}  // namespace linesight
