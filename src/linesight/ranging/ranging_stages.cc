#include "linesight/ranging/ranging_stages.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "linesight/core/disparity.h"
#include "linesight/core/error.h"
#include "linesight/ranging/thin_structures.h"

namespace linesight::detail {

namespace {

// Standard normal density and quantile (a bisection on erfc is exact enough and obviously right).
double NormalDensity(double z) { return std::exp(-0.5 * z * z) / std::sqrt(2.0 * M_PI); }
double NormalQuantile(double p) {
  double lo = -10.0, hi = 10.0;
  for (int i = 0; i < 100; ++i) {
    const double mid = 0.5 * (lo + hi);
    (0.5 * std::erfc(-mid / std::sqrt(2.0)) < p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

// Whole-pixel connected pieces of `mask` (8-connected) that reach into `core`, as a mask; empty
// when none does.
cv::Mat PiecesReaching(const cv::Mat& mask, const cv::Rect& core) {
  cv::Mat labels;
  const int count = cv::connectedComponents(mask, labels, 8, CV_32S);
  std::vector<uchar> in_core(size_t(count), 0);
  for (int y = core.y; y < core.br().y; ++y) {
    for (int x = core.x; x < core.br().x; ++x) in_core[size_t(labels.at<int>(y, x))] = 1;
  }
  in_core[0] = 0;  // background label
  if (std::count(in_core.begin(), in_core.end(), uchar(1)) == 0) return {};
  cv::Mat kept = mask.clone();
  for (int y = 0; y < mask.rows; ++y) {
    for (int x = 0; x < mask.cols; ++x) {
      if (!in_core[size_t(labels.at<int>(y, x))]) kept.at<uchar>(y, x) = 0;
    }
  }
  return kept;
}

// `obstacle` with its holes filled: components of the rest (4-connected) that hold no disparity
// at all and do not reach the ROI's edge (pixels the matcher's checks rejected). Empty if none.
cv::Mat WithRejectedHolesFilled(const cv::Mat& view, const cv::Mat& obstacle) {
  const cv::Mat outside = obstacle == 0;
  cv::Mat labels;
  const int count = cv::connectedComponents(outside, labels, 4, CV_32S);
  std::vector<uchar> hole(size_t(count), 1);
  hole[0] = 0;  // the obstacle
  for (int y = 0; y < view.rows; ++y) {
    const int* label = labels.ptr<int>(y);
    const float* d = view.ptr<float>(y);
    for (int x = 0; x < view.cols; ++x) {
      // Not a hole: a component holding a disparity (another depth) or reaching the ROI's edge.
      if (IsValidDisparity(d[x]) || x == 0 || y == 0 || x == view.cols - 1 || y == view.rows - 1) {
        hole[size_t(label[x])] = 0;
      }
    }
  }
  if (std::count(hole.begin(), hole.end(), uchar(1)) == 0) return {};
  cv::Mat filled = obstacle.clone();
  for (int y = 0; y < view.rows; ++y) {
    const int* label = labels.ptr<int>(y);
    for (int x = 0; x < view.cols; ++x) {
      if (hole[size_t(label[x])]) filled.at<uchar>(y, x) = 1;
    }
  }
  return filled;
}

}  // namespace

double Quantile(std::vector<float> values, double p) { return QuantileInPlace(&values, p); }

double QuantileInPlace(std::vector<float>* reordered, double p) {
  std::vector<float>& values = *reordered;
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

WorkingPixels SelectWorkingPixels(const cv::Mat& view, const StereoGeometry& geometry,
                                  const RangingOptions& options) {
  WorkingPixels w;
  w.d_low = geometry.DisparityFromDepth(options.max_depth_m);
  w.d_high = geometry.DisparityFromDepth(options.min_depth_m);
  w.valid = cv::Mat(view.size(), CV_8U, cv::Scalar(0));
  for (int y = 0; y < view.rows; ++y) {
    const float* d = view.ptr<float>(y);
    for (int x = 0; x < view.cols; ++x) {
      if (IsValidDisparity(d[x]) && d[x] >= w.d_low && d[x] <= w.d_high &&
          d[x] + geometry.disparity_offset_px > 0) {
        w.valid.at<uchar>(y, x) = 1;
        w.values.push_back(d[x]);
      }
    }
  }
  return w;
}

bool KeepBodies(const cv::Mat& disparity, const StereoGeometry& geometry, const cv::Rect& roi,
                const RangingOptions& options, WorkingPixels* pixels) {
  if (options.min_body_width_m <= 0.0) return true;
  ThinStructureOptions thin;
  thin.min_width_m = options.min_body_width_m;
  thin.min_width_px = options.min_body_width_px;
  thin.min_depth_m = options.min_depth_m;
  thin.max_depth_m = options.max_depth_m;
  const cv::Mat body = BodyMask(disparity, geometry, roi, thin);
  const cv::Mat view = disparity(roi);
  std::vector<float> body_values;
  for (int y = 0; y < view.rows; ++y) {
    for (int x = 0; x < view.cols; ++x) {
      if (pixels->valid.at<uchar>(y, x) && body.at<uchar>(y, x))
        body_values.push_back(view.at<float>(y, x));
    }
  }
  if (int(body_values.size()) < options.min_valid_pixels) return false;
  pixels->valid &= body;
  pixels->values = std::move(body_values);
  return true;
}

DepthMode FindObstacleMode(const cv::Mat& view, const WorkingPixels& pixels, double offset,
                           bool only_thin, const RangingOptions& options) {
  const std::vector<float>& values = pixels.values;
  DepthMode mode;
  LogDisparityBins& bins = mode.bins;
  bins.offset = offset;
  bins.width = options.mode_bin_relative;
  bins.log_low = std::log(
      std::max(pixels.d_low, double(*std::min_element(values.begin(), values.end()))) + offset);
  const double log_high = std::log(*std::max_element(values.begin(), values.end()) + offset);
  bins.count = std::max(1, int(std::ceil((log_high - bins.log_low) / bins.width)) + 1);
  std::vector<double> histogram(size_t(bins.count) + 2, 0.0);
  for (float d : values) histogram[size_t(bins.Bin(d))] += 1.0;
  // Support is counted over the core of the ROI (RangingOptions::core_fraction).
  const int core_w = std::max(1, int(std::lround(options.core_fraction * view.cols)));
  const int core_h = std::max(1, int(std::lround(options.core_fraction * view.rows)));
  mode.core = cv::Rect((view.cols - core_w) / 2, (view.rows - core_h) / 2, core_w, core_h);
  std::vector<double> core_histogram(histogram.size(), 0.0);
  int n_core = 0;
  for (int y = mode.core.y; y < mode.core.br().y; ++y) {
    for (int x = mode.core.x; x < mode.core.br().x; ++x) {
      if (!pixels.valid.at<uchar>(y, x)) continue;
      core_histogram[size_t(bins.Bin(view.at<float>(y, x)))] += 1.0;
      ++n_core;
    }
  }
  mode.use_core = n_core >= options.min_valid_pixels;
  const std::vector<double>& support = mode.use_core ? core_histogram : histogram;
  mode.support_pixels = mode.use_core ? n_core : int(values.size());
  std::vector<double> smoothed(histogram.size(), 0.0);  // [1 2 1] / 4
  for (size_t i = 1; i + 1 < histogram.size(); ++i) {
    smoothed[i] = 0.25 * histogram[i - 1] + 0.5 * histogram[i] + 0.25 * histogram[i + 1];
  }
  // Modes = runs of bins above the valley level, searched from the nearest (largest disparity).
  const double level =
      options.mode_valley_fraction * *std::max_element(smoothed.begin(), smoothed.end());
  const bool largest = only_thin && options.largest_mode_without_bodies;
  double best = 0.0;
  for (int i = int(smoothed.size()) - 2; i >= 1 && (largest || !mode.found); --i) {
    if (smoothed[size_t(i)] <= level) continue;
    int j = i;
    double held = 0.0;
    while (j >= 1 && smoothed[size_t(j)] > level) held += support[size_t(j--)];
    if (held >= options.mode_min_support * mode.support_pixels && (!largest || held > best)) {
      mode.found = true;
      mode.first = j + 1;
      mode.last = i;
      best = held;
    }
    i = j;
  }
  // Grown by one bin on each side: the valley test on the smoothed histogram cuts tails early.
  mode.first = std::max(1, mode.first - 1);
  mode.last = std::min(bins.count, mode.last + 1);
  return mode;
}

cv::Mat ObstacleMask(const cv::Mat& view, const WorkingPixels& pixels, const DepthMode& mode) {
  cv::Mat obstacle(view.size(), CV_8U, cv::Scalar(0));
  for (int y = 0; y < view.rows; ++y) {
    const float* d = view.ptr<float>(y);
    for (int x = 0; x < view.cols; ++x) {
      if (!pixels.valid.at<uchar>(y, x)) continue;
      const int b = mode.bins.Bin(d[x]);
      if (b >= mode.first && b <= mode.last) obstacle.at<uchar>(y, x) = 1;
    }
  }
  // Pieces of other objects at the same depth in the ROI's margin are not the obstacle.
  if (!mode.use_core) return obstacle;
  cv::Mat kept = PiecesReaching(obstacle, mode.core);
  return kept.empty() ? obstacle : kept;
}

SmoothedObstacle SmoothObstacle(const cv::Mat& view, const cv::Mat& obstacle, int radius) {
  // The noise level comes from the residuals against a wider median, which also sees correlated
  // matching errors that a 3x3 neighbourhood would hide.
  const int noise_radius = std::max(4, radius);
  SmoothedObstacle s;
  std::vector<float> window;
  auto local_median = [&](int x, int y, int r) {
    window.clear();
    for (int v = std::max(0, y - r); v <= std::min(view.rows - 1, y + r); ++v) {
      for (int u = std::max(0, x - r); u <= std::min(view.cols - 1, x + r); ++u) {
        if (obstacle.at<uchar>(v, u)) window.push_back(view.at<float>(v, u));
      }
    }
    return float(QuantileInPlace(&window, 0.5));
  };
  for (int y = 0; y < view.rows; ++y) {
    for (int x = 0; x < view.cols; ++x) {
      if (!obstacle.at<uchar>(y, x)) continue;
      const float d = view.at<float>(y, x);
      s.points.push_back({x, y});
      s.raw.push_back(d);
      s.residuals.push_back(d - local_median(x, y, noise_radius));
      s.smoothed.push_back(radius == 0 ? d : local_median(x, y, radius));
    }
  }
  return s;
}

cv::Mat InteriorOf(const cv::Mat& shape, const cv::Mat& obstacle, const RangingOptions& options) {
  for (int mx = options.silhouette_margin_x_px, my = options.silhouette_margin_y_px;
       mx > 0 || my > 0; mx = std::max(0, mx - 1), my = std::max(0, my - 1)) {
    cv::Mat eroded;  // a new buffer: eroding in place would shrink `shape` too
    cv::erode(shape, eroded, cv::getStructuringElement(cv::MORPH_RECT, {2 * mx + 1, 2 * my + 1}));
    eroded &= obstacle;
    if (cv::countNonZero(eroded) >= options.min_valid_pixels) return eroded;
  }
  return obstacle.clone();
}

NearSurface NearestSurface(const cv::Mat& view, const cv::Mat& obstacle,
                           const SmoothedObstacle& smoothed, cv::Point roi_origin, double offset,
                           const RangingOptions& options) {
  const double p = options.near_percentile;
  auto surface_of = [&](const cv::Mat& selection) {
    NearSurface near;
    for (size_t i = 0; i < smoothed.points.size(); ++i) {
      if (!selection.at<uchar>(smoothed.points[i])) continue;
      near.values.push_back(smoothed.smoothed[i]);
      near.points.push_back(smoothed.points[i] + roi_origin);
    }
    near.disparity_px = Quantile(near.values, p);
    return near;
  };
  NearSurface near = surface_of(InteriorOf(obstacle, obstacle, options));
  // Rejected pixels scattered over a thin surface (an insulator's 9 px rim at 1 m) each cut a
  // margin out of it and can remove the whole nearest surface from the percentile. The margin is
  // meant for depth edges, and a hole of rejected pixels enclosed by the obstacle is none. With
  // such holes filled, the interior is taken instead when its percentile lies beyond the surface
  // band in front of the first: only then was a surface lost, and otherwise the pixels next to
  // failed matches, more often mixed ones, stay out.
  if (!options.fill_rejected_holes) return near;
  const cv::Mat filled = WithRejectedHolesFilled(view, obstacle);
  if (filled.empty()) return near;
  NearSurface with_holes = surface_of(InteriorOf(filled, obstacle, options));
  if (with_holes.disparity_px + offset >
      (1.0 + options.surface_band_relative) * (near.disparity_px + offset)) {
    return with_holes;
  }
  return near;
}

double NearSurfaceSigma(const NearSurface& near, const SmoothedObstacle& smoothed,
                        const RangingOptions& options) {
  const double p = options.near_percentile;
  const double d_near = near.disparity_px;
  const double m = double(smoothed.points.size());
  const double d_tail = Quantile(near.values, 0.5 * (1.0 + p));
  std::vector<float> residuals = smoothed.residuals;
  for (float& e : residuals) e = std::abs(e);
  const double sigma_residual = 1.4826 * Median(residuals);
  const int r = options.smoothing_radius_px;
  const double window_pixels = double((2 * r + 1) * (2 * r + 1));
  const double correlation_area = options.correlation_length_px * options.correlation_length_px;
  // Smoothing over a window averages only as many independent errors as fit in it.
  const double sigma_smoothed =
      sigma_residual / std::sqrt(std::max(1.0, window_pixels / correlation_area));
  const double effective_samples = std::max(1.0, m / correlation_area);
  const double tail_samples = std::max(1.0, (1.0 - p) * m / correlation_area);
  const double z_p = NormalQuantile(std::min(p, 0.999));
  // The percentile's standard error; with correlated errors never below one independent sample
  // of the tail.
  const double quantile_error =
      sigma_smoothed * std::max(std::sqrt(p * (1.0 - p) / effective_samples) / NormalDensity(z_p),
                                1.0 / std::sqrt(tail_samples));
  // The steepness of the tail (d at the percentile halfway to the maximum minus d_near) bounds how
  // far the nearest visible point can lie beyond the percentile.
  const double tail_step = d_tail - d_near;
  // Half the shift the silhouette pixels cause: how much the choice of pixels matters.
  const double silhouette_shift = 0.5 * std::abs(Quantile(smoothed.smoothed, p) - d_near);
  return std::sqrt(options.disparity_sigma_floor_px * options.disparity_sigma_floor_px +
                   quantile_error * quantile_error + tail_step * tail_step +
                   silhouette_shift * silhouette_shift);
}

}  // namespace linesight::detail
