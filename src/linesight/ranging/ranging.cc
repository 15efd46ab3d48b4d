#include "linesight/ranging/ranging.h"

#include <algorithm>
#include <charconv>
#include <cmath>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "linesight/core/disparity.h"
#include "linesight/core/error.h"
#include "linesight/ranging/ranging_stages.h"

namespace linesight {

DisparityRange DisparityRangeForDepths(const StereoGeometry& geometry, double z_min_m,
                                       double z_max_m, int margin_px) {
  if (!(z_min_m > 0.0) || !std::isfinite(z_min_m)) {
    throw InputError(fmt::format("minimum depth {} m must be a positive number", z_min_m));
  }
  if (!(z_max_m > z_min_m) || !std::isfinite(z_max_m)) {
    throw InputError(
        fmt::format("maximum depth {} m must exceed the minimum depth {} m", z_max_m, z_min_m));
  }
  LS_CHECK(margin_px >= 0);
  const int low = std::max(0, int(std::floor(geometry.DisparityFromDepth(z_max_m))) - margin_px);
  const int high = int(std::ceil(geometry.DisparityFromDepth(z_min_m))) + margin_px;
  DisparityRange range;
  range.min_disparity = low;
  range.num_disparities = std::max(1, high - low + 1);
  return range;
}

DisparityRange DisparityRangeForDepths(const StereoCalibration& calib, double z_min_m,
                                       double z_max_m, int margin_px) {
  return DisparityRangeForDepths(GeometryFromCalibration(calib), z_min_m, z_max_m, margin_px);
}

void RangingOptions::Check() const {
  CheckOption(min_depth_m > 0.0, "RangingOptions.min_depth_m", min_depth_m, "must be > 0");
  CheckOption(max_depth_m > min_depth_m, "RangingOptions.max_depth_m", max_depth_m,
              "must exceed min_depth_m");
  CheckOption(min_valid_pixels >= 1, "RangingOptions.min_valid_pixels", min_valid_pixels,
              "must be >= 1");
  CheckOption(min_valid_fraction >= 0.0 && min_valid_fraction <= 1.0,
              "RangingOptions.min_valid_fraction", min_valid_fraction, "must be in [0, 1]");
  CheckOption(min_body_width_m >= 0.0, "RangingOptions.min_body_width_m", min_body_width_m,
              "must be >= 0 (0 = keep thin structures)");
  CheckOption(mode_bin_relative > 0.0 && mode_bin_relative <= 0.5,
              "RangingOptions.mode_bin_relative", mode_bin_relative, "must be in (0, 0.5]");
  CheckOption(mode_valley_fraction >= 0.0 && mode_valley_fraction < 1.0,
              "RangingOptions.mode_valley_fraction", mode_valley_fraction, "must be in [0, 1)");
  CheckOption(mode_min_support > 0.0 && mode_min_support <= 1.0, "RangingOptions.mode_min_support",
              mode_min_support, "must be in (0, 1]");
  CheckOption(min_body_width_px >= 0.0 && min_body_width_px <= 64.0,
              "RangingOptions.min_body_width_px", min_body_width_px, "must be in [0, 64]");
  CheckOption(core_fraction > 0.0 && core_fraction <= 1.0, "RangingOptions.core_fraction",
              core_fraction, "must be in (0, 1]");
  CheckOption(silhouette_margin_x_px >= 0 && silhouette_margin_x_px <= 15,
              "RangingOptions.silhouette_margin_x_px", silhouette_margin_x_px,
              "must be in [0, 15]");
  CheckOption(silhouette_margin_y_px >= 0 && silhouette_margin_y_px <= 15,
              "RangingOptions.silhouette_margin_y_px", silhouette_margin_y_px,
              "must be in [0, 15]");
  CheckOption(smoothing_radius_px >= 0 && smoothing_radius_px <= 15,
              "RangingOptions.smoothing_radius_px", smoothing_radius_px, "must be in [0, 15]");
  CheckOption(near_percentile >= 0.5 && near_percentile <= 1.0, "RangingOptions.near_percentile",
              near_percentile, "must be in [0.5, 1]");
  CheckOption(surface_band_relative > 0.0 && surface_band_relative <= 0.2,
              "RangingOptions.surface_band_relative", surface_band_relative, "must be in (0, 0.2]");
  CheckOption(disparity_sigma_floor_px >= 0.0, "RangingOptions.disparity_sigma_floor_px",
              disparity_sigma_floor_px, "must be >= 0");
  CheckOption(correlation_length_px >= 1.0, "RangingOptions.correlation_length_px",
              correlation_length_px, "must be >= 1");
}

void CheckRoi(const cv::Rect& roi, cv::Size image_size) {
  if (roi.width <= 0 || roi.height <= 0) {
    throw InputError(fmt::format("ROI {},{},{},{} is empty (width and height must be positive)",
                                 roi.x, roi.y, roi.width, roi.height));
  }
  if (roi.x < 0 || roi.y < 0 || roi.x + roi.width > image_size.width ||
      roi.y + roi.height > image_size.height) {
    throw InputError(fmt::format("ROI {},{},{},{} is not inside the {}x{} image", roi.x, roi.y,
                                 roi.width, roi.height, image_size.width, image_size.height));
  }
}

cv::Rect ParseRoi(const std::string& text) {
  int values[4];
  const char* p = text.data();
  const char* end = text.data() + text.size();
  for (int i = 0; i < 4; ++i) {
    auto [next, ec] = std::from_chars(p, end, values[i]);
    const bool separator_ok = i < 3 ? (next < end && *next == ',') : next == end;
    if (ec != std::errc() || !separator_ok) {
      throw UsageError(fmt::format("--roi '{}': expected x,y,w,h (four integers in pixels)", text));
    }
    p = next + 1;
  }
  return {values[0], values[1], values[2], values[3]};
}

namespace {

RangeResult NoMeasurement(RangeResult result, std::string reason) {
  result.status = RangeStatus::kNoMeasurement;
  result.reason = std::move(reason);
  return result;
}

}  // namespace

RangeResult RangeObstacle(const cv::Mat& disparity, const StereoGeometry& geometry,
                          const cv::Rect& roi, const RangingOptions& options) {
  options.Check();
  CheckDisparityMap(disparity, "disparity");
  CheckRoi(roi, disparity.size());
  RangeResult result;
  result.roi = roi;
  const cv::Mat view = disparity(roi);
  const double offset = geometry.disparity_offset_px;

  detail::WorkingPixels pixels = detail::SelectWorkingPixels(view, geometry, options);
  const int n = int(pixels.values.size());
  result.valid_fraction = double(n) / double(roi.area());
  if (n == 0) {
    return NoMeasurement(result, fmt::format("no valid disparity in the ROI for depths {}..{} m",
                                             options.min_depth_m, options.max_depth_m));
  }
  if (n < options.min_valid_pixels || result.valid_fraction < options.min_valid_fraction) {
    return NoMeasurement(
        result, fmt::format("only {} valid pixels ({:.1f} % of the ROI); need {} and {:.1f} %", n,
                            100.0 * result.valid_fraction, options.min_valid_pixels,
                            100.0 * options.min_valid_fraction));
  }
  const bool only_thin = !detail::KeepBodies(disparity, geometry, roi, options, &pixels);
  const detail::DepthMode mode = detail::FindObstacleMode(view, pixels, offset, only_thin, options);
  if (!mode.found) {
    return NoMeasurement(result,
                         fmt::format("no depth mode holds {:.0f} % of the {} valid pixels{}",
                                     100.0 * options.mode_min_support, mode.support_pixels,
                                     mode.use_core ? " in the ROI's core" : ""));
  }
  const cv::Mat obstacle = detail::ObstacleMask(view, pixels, mode);
  const int m = cv::countNonZero(obstacle);
  if (m < options.min_valid_pixels) {
    return NoMeasurement(result, fmt::format("the nearest depth mode has only {} pixels; need {}",
                                             m, options.min_valid_pixels));
  }
  result.obstacle_pixels = m;
  result.box = cv::boundingRect(obstacle) + roi.tl();

  const detail::SmoothedObstacle smoothed =
      detail::SmoothObstacle(view, obstacle, options.smoothing_radius_px);
  const detail::NearSurface near =
      detail::NearestSurface(view, obstacle, smoothed, roi.tl(), offset, options);
  const double d_near = near.disparity_px;
  const double sigma_d = detail::NearSurfaceSigma(near, smoothed, options);
  result.disparity_px = d_near;
  result.matched_disparity_px = d_near;
  result.disparity_sigma_px = sigma_d;
  // The nearest surface: the interior pixels within surface_band_relative of d_near.
  const double surface_floor = (1.0 - options.surface_band_relative) * (d_near + offset) - offset;
  double surface_sum = 0.0;
  for (size_t i = 0; i < near.values.size(); ++i) {
    if (near.values[i] < surface_floor) continue;
    result.surface_pixels.push_back(near.points[i]);
    surface_sum += near.values[i];
  }
  result.surface_disparity_px =
      surface_sum / double(std::max<size_t>(1, result.surface_pixels.size()));
  result.distance_m = geometry.DepthFromDisparity(d_near);
  result.sigma_m = geometry.DepthSigma(result.distance_m, sigma_d);
  result.median_distance_m = geometry.DepthFromDisparity(detail::Median(smoothed.raw));
  result.status = RangeStatus::kOk;
  return result;
}

RangeResult RangeObstacle(const cv::Mat& disparity, const StereoCalibration& calib,
                          const cv::Rect& roi, const RangingOptions& options) {
  return RangeObstacle(disparity, GeometryFromCalibration(calib), roi, options);
}

nlohmann::json RangeResultToJson(const RangeResult& result) {
  nlohmann::json j;
  j["roi"] = {result.roi.x, result.roi.y, result.roi.width, result.roi.height};
  j["valid_fraction"] = result.valid_fraction;
  if (result.ok()) {
    j["status"] = "ok";
    j["distance_m"] = result.distance_m;
    j["sigma_m"] = result.sigma_m;
    j["box"] = {result.box.x, result.box.y, result.box.width, result.box.height};
    j["obstacle_pixels"] = result.obstacle_pixels;
    j["disparity_px"] = result.disparity_px;
    j["disparity_sigma_px"] = result.disparity_sigma_px;
    j["median_distance_m"] = result.median_distance_m;
    j["surface_pixels"] = result.surface_pixels.size();
    j["refined"] = result.refined;
    if (result.refinement.empty()) {
      j["refinement"] = nullptr;
    } else {
      j["refinement"] = result.refinement;
    }
    j["matched_disparity_px"] = result.matched_disparity_px;
    if (std::isfinite(result.surface_check_px)) {
      j["surface_check_px"] = result.surface_check_px;
    } else {
      j["surface_check_px"] = nullptr;
    }
  } else {
    j["status"] = "no_measurement";
    j["reason"] = result.reason;
    j["distance_m"] = nullptr;
    j["sigma_m"] = nullptr;
  }
  return j;
}

cv::Rect GrowRoiByPixels(const cv::Rect& box, int grow_x_px, int grow_y_px, cv::Size image_size) {
  return cv::Rect(box.x - grow_x_px, box.y - grow_y_px, box.width + 2 * grow_x_px,
                  box.height + 2 * grow_y_px) &
         cv::Rect(cv::Point(0, 0), image_size);
}

cv::Rect GrowRoi(const cv::Rect& box, cv::Size image_size, double fraction, int margin_px) {
  return GrowRoiByPixels(box, static_cast<int>(fraction * box.width) + margin_px,
                         static_cast<int>(fraction * box.height) + margin_px, image_size);
}

RangeRunStats SummariseRangeRuns(const std::vector<RangeResult>& results,
                                 const std::vector<double>& truths) {
  LS_CHECK(results.size() == truths.size());
  RangeRunStats s;
  s.runs = static_cast<int>(results.size());
  std::vector<double> d;
  for (size_t i = 0; i < results.size(); ++i) {
    const RangeResult& r = results[i];
    if (!r.ok()) {
      ++s.failures[r.reason];
      continue;
    }
    d.push_back(r.distance_m);
    s.mean_sigma_m += r.sigma_m;
    s.mean_abs_relative += std::abs(r.distance_m - truths[i]) / truths[i];
    s.covered += std::abs(r.distance_m - truths[i]) <= 2.0 * r.sigma_m;
  }
  s.measured = static_cast<int>(d.size());
  if (d.empty()) return s;
  const double n = static_cast<double>(d.size());
  for (const double v : d) s.mean_m += v;
  s.mean_m /= n;
  double ss = 0.0;
  for (const double v : d) ss += (v - s.mean_m) * (v - s.mean_m);
  s.std_m = d.size() > 1 ? std::sqrt(ss / (n - 1.0)) : 0.0;
  s.mean_sigma_m /= n;
  s.mean_abs_relative /= n;
  return s;
}

}  // namespace linesight
