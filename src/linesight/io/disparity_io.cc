#include "linesight/io/disparity_io.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "linesight/core/disparity.h"
#include "linesight/core/error.h"
#include "linesight/io/image_io.h"
#include "linesight/io/pfm.h"

namespace linesight {
namespace fs = std::filesystem;

namespace {

constexpr double kKittiMaxValue = 65535.0;

std::string LowerExtension(const fs::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return ext;
}

void CheckDisparityMat(const cv::Mat& disparity, const char* what) {
  if (disparity.empty() || disparity.type() != CV_32FC1) {
    throw InputError(
        fmt::format("{}: the disparity map must be a non-empty CV_32FC1 matrix, got {}x{} with "
                    "type {}",
                    what, disparity.cols, disparity.rows, disparity.type()));
  }
}

// The display range: [min_d, max_d] when it is a proper interval, else the range of the valid
// values. Returns false when there is nothing to show (no valid value and no range given).
bool DisplayRange(const cv::Mat& disparity, float& min_d, float& max_d) {
  if (max_d > min_d && std::isfinite(min_d) && std::isfinite(max_d)) return true;
  float lo = kInvalidDisparity, hi = -kInvalidDisparity;
  for (int y = 0; y < disparity.rows; ++y) {
    const float* row = disparity.ptr<float>(y);
    for (int x = 0; x < disparity.cols; ++x) {
      if (!IsValidDisparity(row[x])) continue;
      lo = std::min(lo, row[x]);
      hi = std::max(hi, row[x]);
    }
  }
  if (!(hi >= lo)) return false;
  if (hi == lo) hi = lo + 1;  // a constant map shows as the low end of the colour scale
  min_d = lo;
  max_d = hi;
  return true;
}

// 1-2-5 tick step giving about `target` intervals over `span`.
double NiceStep(double span, int target) {
  const double raw = span / std::max(target, 1);
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0, 10.0}) {
    if (m * magnitude >= raw) return m * magnitude;
  }
  return 10 * magnitude;
}

std::string TickLabel(double value, double step) {
  const int decimals = step >= 1 ? 0 : static_cast<int>(std::ceil(-std::log10(step) - 1e-9));
  return fmt::format("{:.{}f}", value, decimals);
}

}  // namespace

cv::Mat ReadKittiDisparity(const fs::path& path) {
  const cv::Mat raw = ReadImage(path, ImageColor::kUnchanged);
  if (raw.type() != CV_16UC1) {
    throw InputError(
        fmt::format("{}: not a KITTI disparity PNG: expected a 16-bit single-channel image "
                    "(value = disparity * 256, 0 = unknown), got {}-bit with {} channel(s)",
                    path.string(), raw.depth() == CV_16U ? 16 : (raw.depth() == CV_8U ? 8 : 32),
                    raw.channels()));
  }
  cv::Mat disparity(raw.size(), CV_32FC1);
  for (int y = 0; y < raw.rows; ++y) {
    const std::uint16_t* src = raw.ptr<std::uint16_t>(y);
    float* dst = disparity.ptr<float>(y);
    for (int x = 0; x < raw.cols; ++x) {
      dst[x] = src[x] == 0 ? kInvalidDisparity : static_cast<float>(src[x]) / kKittiDisparityScale;
    }
  }
  return disparity;
}

void WriteKittiDisparity(const fs::path& path, const cv::Mat& disparity) {
  CheckDisparityMat(disparity, path.string().c_str());
  cv::Mat raw(disparity.size(), CV_16UC1);
  for (int y = 0; y < disparity.rows; ++y) {
    const float* src = disparity.ptr<float>(y);
    std::uint16_t* dst = raw.ptr<std::uint16_t>(y);
    for (int x = 0; x < disparity.cols; ++x) {
      if (!IsValidDisparity(src[x])) {
        dst[x] = 0;
        continue;
      }
      const double scaled = std::round(static_cast<double>(src[x]) * kKittiDisparityScale);
      dst[x] = static_cast<std::uint16_t>(std::clamp(scaled, 1.0, kKittiMaxValue));
    }
  }
  if (LowerExtension(path) != ".png") {
    throw InputError(
        fmt::format("{}: a KITTI disparity map must be written as .png", path.string()));
  }
  WriteImage(path, raw);
}

cv::Mat ReadDisparity(const fs::path& path) {
  const std::string ext = LowerExtension(path);
  if (ext == ".pfm") {
    cv::Mat disparity = ReadPfm(path);
    if (disparity.channels() != 1) {
      throw InputError(
          fmt::format("{}: a disparity map must be a grey \"Pf\" PFM, this is a colour \"PF\" one",
                      path.string()));
    }
    return disparity;
  }
  if (ext == ".png") return ReadKittiDisparity(path);
  throw InputError(
      fmt::format("{}: unknown disparity format '{}' (expected .pfm, or .png in KITTI uint16 "
                  "encoding)",
                  path.string(), path.extension().string()));
}

cv::Mat ColorizeDisparity(const cv::Mat& disparity, float min_d, float max_d) {
  CheckDisparityMat(disparity, "ColorizeDisparity");
  cv::Mat color(disparity.size(), CV_8UC3, cv::Scalar::all(0));
  if (!DisplayRange(disparity, min_d, max_d)) return color;
  cv::Mat level(disparity.size(), CV_8UC1);
  const float scale = 255.0f / (max_d - min_d);
  for (int y = 0; y < disparity.rows; ++y) {
    const float* src = disparity.ptr<float>(y);
    std::uint8_t* dst = level.ptr<std::uint8_t>(y);
    for (int x = 0; x < disparity.cols; ++x) {
      const float d = IsValidDisparity(src[x]) ? src[x] : min_d;
      dst[x] = cv::saturate_cast<std::uint8_t>((d - min_d) * scale);
    }
  }
  cv::applyColorMap(level, color, cv::COLORMAP_TURBO);
  for (int y = 0; y < disparity.rows; ++y) {
    const float* src = disparity.ptr<float>(y);
    cv::Vec3b* dst = color.ptr<cv::Vec3b>(y);
    for (int x = 0; x < disparity.cols; ++x) {
      if (!IsValidDisparity(src[x])) dst[x] = cv::Vec3b(0, 0, 0);
    }
  }
  return color;
}

cv::Mat ColorizeDisparityWithLegend(const cv::Mat& disparity, float min_d, float max_d) {
  const cv::Mat image = ColorizeDisparity(disparity, min_d, max_d);
  const int width = image.cols;
  const double font_scale = std::clamp(width / 1000.0, 0.3, 1.0);
  const int thickness = font_scale > 0.6 ? 2 : 1;
  int baseline = 0;
  const cv::Size text_size =
      cv::getTextSize("0123456789", cv::FONT_HERSHEY_SIMPLEX, font_scale, thickness, &baseline);
  const int margin = std::max(2, width / 100);
  const int bar_height = std::max(8, image.rows / 25);
  const int tick_height = std::max(3, bar_height / 3);
  const int legend_height =
      margin + bar_height + tick_height + margin + text_size.height + baseline + margin;
  cv::Mat out(image.rows + legend_height, width, CV_8UC3, cv::Scalar::all(0));
  image.copyTo(out(cv::Rect(0, 0, width, image.rows)));

  const cv::Scalar text_color(255, 255, 255);
  const int bar_top = image.rows + margin;
  const int bar_left = margin,
            bar_right = width - 1 - margin;  // inclusive pixel columns of the bar
  if (!DisplayRange(disparity, min_d, max_d) || bar_right - bar_left < 2) {
    cv::putText(out, "no valid disparity", cv::Point(margin, bar_top + text_size.height),
                cv::FONT_HERSHEY_SIMPLEX, font_scale, text_color, thickness, cv::LINE_AA);
    return out;
  }
  // The bar: column x shows the colour of the disparity at that position of the range.
  cv::Mat ramp(1, bar_right - bar_left + 1, CV_8UC1);
  for (int i = 0; i < ramp.cols; ++i) {
    ramp.at<std::uint8_t>(0, i) = cv::saturate_cast<std::uint8_t>(255.0 * i / (ramp.cols - 1));
  }
  cv::Mat ramp_color;
  cv::applyColorMap(ramp, ramp_color, cv::COLORMAP_TURBO);
  cv::repeat(ramp_color, bar_height, 1, out(cv::Rect(bar_left, bar_top, ramp.cols, bar_height)));

  // Ticks at round values with labels in pixels; labels that would overlap the previous one are
  // skipped.
  const double span = max_d - min_d;
  const int max_labels = std::max(2, (bar_right - bar_left) / (text_size.width / 2 + margin));
  const double step = NiceStep(span, std::min(8, max_labels));
  int last_label_right = std::numeric_limits<int>::min() / 2;  // no label yet
  const int text_y = bar_top + bar_height + tick_height + margin + text_size.height;
  const double first_tick = std::ceil(min_d / step - 1e-9);
  for (int k = 0; k <= 20; ++k) {
    const double value = (first_tick + k) * step;
    if (value > max_d + 1e-9 * span) break;
    const int x =
        bar_left + static_cast<int>(std::lround((value - min_d) / span * (bar_right - bar_left)));
    cv::line(out, cv::Point(x, bar_top + bar_height),
             cv::Point(x, bar_top + bar_height + tick_height - 1), text_color, 1);
    const std::string label = TickLabel(std::abs(value) < step * 1e-6 ? 0.0 : value, step);
    const cv::Size label_size =
        cv::getTextSize(label, cv::FONT_HERSHEY_SIMPLEX, font_scale, thickness, &baseline);
    const int left = std::clamp(x - label_size.width / 2, 0, width - label_size.width);
    if (left <= last_label_right + margin) continue;
    cv::putText(out, label, cv::Point(left, text_y), cv::FONT_HERSHEY_SIMPLEX, font_scale,
                text_color, thickness, cv::LINE_AA);
    last_label_right = left + label_size.width;
  }
  // The unit, at the right end if there is room.
  const cv::Size unit_size =
      cv::getTextSize("[px]", cv::FONT_HERSHEY_SIMPLEX, font_scale, thickness, &baseline);
  if (width - unit_size.width > last_label_right + margin) {
    cv::putText(out, "[px]", cv::Point(width - unit_size.width, text_y), cv::FONT_HERSHEY_SIMPLEX,
                font_scale, text_color, thickness, cv::LINE_AA);
  }
  return out;
}

cv::Mat ColorizeDisparityError(const cv::Mat& disparity, const cv::Mat& ground_truth,
                               float max_error) {
  CheckDisparityMat(disparity, "ColorizeDisparityError (disparity)");
  CheckDisparityMat(ground_truth, "ColorizeDisparityError (ground truth)");
  if (disparity.size() != ground_truth.size()) {
    throw InputError(
        fmt::format("ColorizeDisparityError: the disparity map is {}x{} but the ground truth is "
                    "{}x{}",
                    disparity.cols, disparity.rows, ground_truth.cols, ground_truth.rows));
  }
  CheckOption(max_error > 0 && std::isfinite(max_error), "ColorizeDisparityError.max_error",
              max_error, "must be a finite positive number of pixels");
  cv::Mat level(disparity.size(), CV_8UC1);
  for (int y = 0; y < disparity.rows; ++y) {
    const float* d = disparity.ptr<float>(y);
    const float* gt = ground_truth.ptr<float>(y);
    std::uint8_t* dst = level.ptr<std::uint8_t>(y);
    for (int x = 0; x < disparity.cols; ++x) {
      const float error =
          IsValidDisparity(d[x]) && IsValidDisparity(gt[x]) ? std::abs(d[x] - gt[x]) : 0.0f;
      dst[x] = cv::saturate_cast<std::uint8_t>(std::min(error / max_error, 1.0f) * 255.0f);
    }
  }
  cv::Mat color;
  cv::applyColorMap(level, color, cv::COLORMAP_TURBO);
  for (int y = 0; y < disparity.rows; ++y) {
    const float* d = disparity.ptr<float>(y);
    const float* gt = ground_truth.ptr<float>(y);
    cv::Vec3b* dst = color.ptr<cv::Vec3b>(y);
    for (int x = 0; x < disparity.cols; ++x) {
      if (!IsValidDisparity(gt[x])) {
        dst[x] = cv::Vec3b(0, 0, 0);
      } else if (!IsValidDisparity(d[x])) {
        dst[x] = cv::Vec3b(255, 255, 255);
      }
    }
  }
  return color;
}

}  // namespace linesight
