#include "linesight/ranging/ranging.h"

#include <algorithm>
#include <charconv>
#include <cmath>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "linesight/core/disparity.h"
#include "linesight/core/error.h"
#include "linesight/ranging/thin_structures.h"

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

double Quantile(std::vector<float> values, double p) {
  LS_CHECK(!values.empty());
  const double position = p * double(values.size() - 1);
  const size_t lo = size_t(std::floor(position));
  const size_t hi = std::min(values.size() - 1, lo + 1);
  std::nth_element(values.begin(), values.begin() + lo, values.end());
  const double a = values[lo];
  if (hi == lo) return a;
  const double b = *std::min_element(values.begin() + lo + 1, values.end());
  return a + (position - double(lo)) * (b - a);
}

double Median(std::vector<float> values) { return Quantile(std::move(values), 0.5); }

// Standard normal density and quantile (Acklam's rational approximation is more than we need here:
// a bisection on erfc is exact enough and obviously right).
double NormalDensity(double z) { return std::exp(-0.5 * z * z) / std::sqrt(2.0 * M_PI); }
double NormalQuantile(double p) {
  double lo = -10.0, hi = 10.0;
  for (int i = 0; i < 100; ++i) {
    const double mid = 0.5 * (lo + hi);
    (0.5 * std::erfc(-mid / std::sqrt(2.0)) < p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

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

  // Stage 1: valid disparities inside the working depth range.
  const double d_low = geometry.DisparityFromDepth(options.max_depth_m);
  const double d_high = geometry.DisparityFromDepth(options.min_depth_m);
  const cv::Mat view = disparity(roi);
  cv::Mat valid(roi.size(), CV_8U, cv::Scalar(0));
  std::vector<float> values;
  for (int y = 0; y < view.rows; ++y) {
    const float* d = view.ptr<float>(y);
    for (int x = 0; x < view.cols; ++x) {
      if (IsValidDisparity(d[x]) && d[x] >= d_low && d[x] <= d_high &&
          d[x] + geometry.disparity_offset_px > 0) {
        valid.at<uchar>(y, x) = 1;
        values.push_back(d[x]);
      }
    }
  }
  const int n = int(values.size());
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

  bool only_thin = false;  // the thin-structure filter left too few pixels: all are used
  // Stage 1b: drop thin structures (a conductor passing in front of or behind the obstacle).
  if (options.min_body_width_m > 0.0) {
    ThinStructureOptions thin;
    thin.min_width_m = options.min_body_width_m;
    thin.min_width_px = options.min_body_width_px;
    thin.min_depth_m = options.min_depth_m;
    thin.max_depth_m = options.max_depth_m;
    const cv::Mat body = BodyMask(disparity, geometry, roi, thin);
    std::vector<float> body_values;
    for (int y = 0; y < view.rows; ++y) {
      for (int x = 0; x < view.cols; ++x) {
        if (valid.at<uchar>(y, x) && body.at<uchar>(y, x))
          body_values.push_back(view.at<float>(y, x));
      }
    }
    if (int(body_values.size()) >= options.min_valid_pixels) {
      valid &= body;
      values = std::move(body_values);
    } else {
      only_thin = true;
    }
  }

  // Stage 2: histogram of log-disparity (bins of equal relative depth width), smoothed with [1 2
  // 1].
  const double offset = geometry.disparity_offset_px;
  auto log_of = [&](double d) { return std::log(d + offset); };
  const double log_low =
      log_of(std::max(d_low, double(*std::min_element(values.begin(), values.end()))));
  const double log_high = log_of(*std::max_element(values.begin(), values.end()));
  const int bins =
      std::max(1, int(std::ceil((log_high - log_low) / options.mode_bin_relative)) + 1);
  std::vector<double> histogram(size_t(bins) + 2, 0.0);  // one empty guard bin at each end
  auto bin_of = [&](double d) {
    return 1 + std::clamp(int((log_of(d) - log_low) / options.mode_bin_relative), 0, bins - 1);
  };
  for (float d : values) histogram[size_t(bin_of(d))] += 1.0;
  const int n_used = int(values.size());
  // The core of the ROI, where mode support is counted (see RangingOptions::core_fraction).
  const int core_w = std::max(1, int(std::lround(options.core_fraction * roi.width)));
  const int core_h = std::max(1, int(std::lround(options.core_fraction * roi.height)));
  const cv::Rect core((roi.width - core_w) / 2, (roi.height - core_h) / 2, core_w, core_h);
  std::vector<double> core_histogram(histogram.size(), 0.0);
  int n_core = 0;
  for (int y = core.y; y < core.br().y; ++y) {
    for (int x = core.x; x < core.br().x; ++x) {
      if (!valid.at<uchar>(y, x)) continue;
      core_histogram[size_t(bin_of(view.at<float>(y, x)))] += 1.0;
      ++n_core;
    }
  }
  const bool use_core = n_core >= options.min_valid_pixels;
  const std::vector<double>& support_histogram = use_core ? core_histogram : histogram;
  const int n_support = use_core ? n_core : n_used;
  std::vector<double> smoothed(histogram.size(), 0.0);
  for (size_t i = 1; i + 1 < histogram.size(); ++i) {
    smoothed[i] = 0.25 * histogram[i - 1] + 0.5 * histogram[i] + 0.25 * histogram[i + 1];
  }

  // Stage 3: depth modes = runs of bins above the valley level; the obstacle is the nearest
  // (largest disparity) mode holding enough of the valid pixels.
  const double peak = *std::max_element(smoothed.begin(), smoothed.end());
  const double level = options.mode_valley_fraction * peak;
  int mode_first = -1, mode_last = -1;
  // Without any body left (only_thin), the nearest mode is whatever thin piece lies nearest --
  // typically the conductor running towards the camera into the obstacle; the obstacle is then
  // the mode with the most support in the core (RangingOptions::largest_mode_without_bodies).
  const bool largest = only_thin && options.largest_mode_without_bodies;
  double best = 0.0;
  for (int i = int(smoothed.size()) - 2; i >= 1 && (largest || mode_first < 0); --i) {
    if (smoothed[size_t(i)] <= level) continue;
    int j = i;
    double support = 0.0;
    while (j >= 1 && smoothed[size_t(j)] > level) support += support_histogram[size_t(j--)];
    if (support >= options.mode_min_support * n_support && (!largest || support > best)) {
      mode_first = j + 1;
      mode_last = i;
      best = support;
    }
    i = j;
  }
  if (mode_first < 0) {
    return NoMeasurement(result,
                         fmt::format("no depth mode holds {:.0f} % of the {} valid pixels{}",
                                     100.0 * options.mode_min_support, n_support,
                                     use_core ? " in the ROI's core" : ""));
  }
  // Grow by one bin on each side: the valley test on the smoothed histogram cuts tails early.
  mode_first = std::max(1, mode_first - 1);
  mode_last = std::min(bins, mode_last + 1);

  cv::Mat obstacle(roi.size(), CV_8U, cv::Scalar(0));
  for (int y = 0; y < view.rows; ++y) {
    const float* d = view.ptr<float>(y);
    for (int x = 0; x < view.cols; ++x) {
      if (!valid.at<uchar>(y, x)) continue;
      const int b = bin_of(d[x]);
      if (b >= mode_first && b <= mode_last) obstacle.at<uchar>(y, x) = 1;
    }
  }
  // Keep the mode's connected pieces that reach into the core: pieces of other objects at the
  // same depth in the ROI's margin are not the obstacle. All pieces if none reaches the core.
  if (use_core) {
    cv::Mat labels;
    const int count = cv::connectedComponents(obstacle, labels, 8, CV_32S);
    std::vector<uchar> in_core(size_t(count), 0);
    for (int y = core.y; y < core.br().y; ++y) {
      for (int x = core.x; x < core.br().x; ++x) in_core[size_t(labels.at<int>(y, x))] = 1;
    }
    in_core[0] = 0;  // background label
    if (std::count(in_core.begin(), in_core.end(), uchar(1)) > 0) {
      for (int y = 0; y < view.rows; ++y) {
        for (int x = 0; x < view.cols; ++x) {
          if (!in_core[size_t(labels.at<int>(y, x))]) obstacle.at<uchar>(y, x) = 0;
        }
      }
    }
  }
  std::vector<float> obstacle_values;
  int min_x = roi.width, min_y = roi.height, max_x = -1, max_y = -1;
  for (int y = 0; y < view.rows; ++y) {
    const float* d = view.ptr<float>(y);
    for (int x = 0; x < view.cols; ++x) {
      if (!obstacle.at<uchar>(y, x)) continue;
      obstacle_values.push_back(d[x]);
      min_x = std::min(min_x, x);
      max_x = std::max(max_x, x);
      min_y = std::min(min_y, y);
      max_y = std::max(max_y, y);
    }
  }
  const int m = int(obstacle_values.size());
  if (m < options.min_valid_pixels) {
    return NoMeasurement(result, fmt::format("the nearest depth mode has only {} pixels; need {}",
                                             m, options.min_valid_pixels));
  }
  result.obstacle_pixels = m;
  result.box = cv::Rect(roi.x + min_x, roi.y + min_y, max_x - min_x + 1, max_y - min_y + 1);

  // Stage 4: local median of the obstacle's disparities (only obstacle pixels vote). The noise
  // level comes from the residuals against a wider median (radius noise_radius), which also sees
  // correlated matching errors that a 3x3 neighbourhood would hide.
  const int r = options.smoothing_radius_px;
  const int noise_radius = std::max(4, r);
  std::vector<float> all_smoothed_values, residuals, window;
  std::vector<cv::Point> all_points;  // ROI coordinates of all_smoothed_values
  all_smoothed_values.reserve(size_t(m));
  residuals.reserve(size_t(m));
  auto local_median = [&](int x, int y, int radius) {
    window.clear();
    for (int v = std::max(0, y - radius); v <= std::min(view.rows - 1, y + radius); ++v) {
      for (int u = std::max(0, x - radius); u <= std::min(view.cols - 1, x + radius); ++u) {
        if (obstacle.at<uchar>(v, u)) window.push_back(view.at<float>(v, u));
      }
    }
    return float(Median(window));
  };
  for (int y = 0; y < view.rows; ++y) {
    for (int x = 0; x < view.cols; ++x) {
      if (!obstacle.at<uchar>(y, x)) continue;
      residuals.push_back(view.at<float>(y, x) - local_median(x, y, noise_radius));
      all_smoothed_values.push_back(r == 0 ? view.at<float>(y, x) : local_median(x, y, r));
      all_points.push_back({x, y});
    }
  }

  // Pixels away from the mode's silhouette (see RangingOptions::silhouette_margin_x_px).
  // On a small obstacle the full margin may leave fewer than min_valid_pixels: the margin then
  // shrinks one pixel at a time (both directions) until enough remain, so that the pixels nearest
  // the silhouette -- the most fattened ones -- are still left out.
  auto interior_of = [&](const cv::Mat& shape) {
    for (int mx = options.silhouette_margin_x_px, my = options.silhouette_margin_y_px;
         mx > 0 || my > 0; mx = std::max(0, mx - 1), my = std::max(0, my - 1)) {
      cv::Mat eroded;  // a new buffer: eroding in place would shrink `shape` too
      cv::erode(shape, eroded, cv::getStructuringElement(cv::MORPH_RECT, {2 * mx + 1, 2 * my + 1}));
      eroded &= obstacle;
      if (cv::countNonZero(eroded) >= options.min_valid_pixels) return eroded;
    }
    return obstacle.clone();
  };
  const double p = options.near_percentile;
  // The smoothed values of the pixels in `selection`, and their image coordinates.
  auto values_in = [&](const cv::Mat& selection, std::vector<cv::Point>& points) {
    std::vector<float> selected;
    for (size_t i = 0; i < all_points.size(); ++i) {
      if (!selection.at<uchar>(all_points[i])) continue;
      selected.push_back(all_smoothed_values[i]);
      points.push_back(all_points[i] + roi.tl());
    }
    return selected;
  };
  std::vector<cv::Point> smoothed_points;  // image coordinates of smoothed_values
  std::vector<float> smoothed_values = values_in(interior_of(obstacle), smoothed_points);
  double d_near = Quantile(smoothed_values, p);
  // Rejected pixels (no disparity: the matcher's checks failed) scattered over a thin surface --
  // an insulator's 9 px rim at 1 m -- each cut a margin out of it and can remove the whole nearest
  // surface from the percentile (`eval ranging`, insulator at 1 m: 3 of 8 runs 3 px too far). The
  // margin is meant for depth edges, where a neighbour's disparity spreads over the obstacle, and
  // a hole of rejected pixels enclosed by the obstacle is none. With such holes filled, the
  // interior is taken instead when its near percentile lies beyond the surface band
  // (surface_band_relative) in front of the first: only then was a surface lost, and otherwise the
  // pixels next to failed matches, more often mixed ones, stay out.
  if (options.fill_rejected_holes) {
    cv::Mat outside = obstacle == 0;
    cv::Mat labels;
    const int count = cv::connectedComponents(outside, labels, 4, CV_32S);
    std::vector<uchar> hole(size_t(count), 1);
    hole[0] = 0;  // the obstacle
    for (int y = 0; y < view.rows; ++y) {
      const int* label = labels.ptr<int>(y);
      const float* d = view.ptr<float>(y);
      for (int x = 0; x < view.cols; ++x) {
        // Not a hole: a component holding a disparity (another depth) or reaching the ROI's edge.
        if (IsValidDisparity(d[x]) || x == 0 || y == 0 || x == view.cols - 1 ||
            y == view.rows - 1) {
          hole[size_t(label[x])] = 0;
        }
      }
    }
    if (std::count(hole.begin(), hole.end(), uchar(1)) > 0) {
      cv::Mat filled = obstacle.clone();
      for (int y = 0; y < view.rows; ++y) {
        const int* label = labels.ptr<int>(y);
        for (int x = 0; x < view.cols; ++x) {
          if (hole[size_t(label[x])]) filled.at<uchar>(y, x) = 1;
        }
      }
      std::vector<cv::Point> filled_points;
      std::vector<float> filled_values = values_in(interior_of(filled), filled_points);
      const double filled_near = Quantile(filled_values, p);
      if (filled_near + offset > (1.0 + options.surface_band_relative) * (d_near + offset)) {
        d_near = filled_near;
        smoothed_values = std::move(filled_values);
        smoothed_points = std::move(filled_points);
      }
    }
  }

  // Stage 5: nearest surface and uncertainty. sigma_d combines (in quadrature) the floor, the
  // standard error of the percentile (with correlated errors: never below one independent sample of
  // the tail), and the steepness of the tail (d at the percentile halfway to the maximum minus
  // d_near), which bounds how far the nearest visible point can lie beyond the percentile.
  const double d_tail = Quantile(smoothed_values, 0.5 * (1.0 + p));
  for (float& e : residuals) e = std::abs(e);
  const double sigma_residual = 1.4826 * Median(residuals);
  const double window_pixels = double((2 * r + 1) * (2 * r + 1));
  const double correlation_area = options.correlation_length_px * options.correlation_length_px;
  // Smoothing over a window averages only as many independent errors as fit in it.
  const double sigma_smoothed =
      sigma_residual / std::sqrt(std::max(1.0, window_pixels / correlation_area));
  const double effective_samples = std::max(1.0, double(m) / correlation_area);
  const double tail_samples = std::max(1.0, (1.0 - p) * double(m) / correlation_area);
  const double z_p = NormalQuantile(std::min(p, 0.999));
  const double quantile_error =
      sigma_smoothed * std::max(std::sqrt(p * (1.0 - p) / effective_samples) / NormalDensity(z_p),
                                1.0 / std::sqrt(tail_samples));
  const double tail_step = d_tail - d_near;
  // Half the shift the silhouette pixels cause: how much the choice of pixels matters.
  const double silhouette_shift = 0.5 * std::abs(Quantile(all_smoothed_values, p) - d_near);
  const double sigma_d =
      std::sqrt(options.disparity_sigma_floor_px * options.disparity_sigma_floor_px +
                quantile_error * quantile_error + tail_step * tail_step +
                silhouette_shift * silhouette_shift);
  result.disparity_px = d_near;
  result.matched_disparity_px = d_near;
  result.disparity_sigma_px = sigma_d;
  const double surface_floor = (1.0 - options.surface_band_relative) * (d_near + offset) - offset;
  double surface_sum = 0.0;
  for (size_t i = 0; i < smoothed_values.size(); ++i) {
    if (smoothed_values[i] < surface_floor) continue;
    result.surface_pixels.push_back(smoothed_points[i]);
    surface_sum += smoothed_values[i];
  }
  result.surface_disparity_px =
      surface_sum / double(std::max<size_t>(1, result.surface_pixels.size()));
  result.distance_m = geometry.DepthFromDisparity(d_near);
  result.sigma_m = geometry.DepthSigma(result.distance_m, sigma_d);
  result.median_distance_m = geometry.DepthFromDisparity(Median(obstacle_values));
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
