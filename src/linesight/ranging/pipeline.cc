#include "linesight/ranging/pipeline.h"

#include <cmath>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "linesight/core/disparity.h"
#include "linesight/core/error.h"
#include "linesight/core/timer.h"

namespace linesight {

std::map<std::string, std::string> RangingMatcherParams(const std::string& method,
                                                        std::map<std::string, std::string> params) {
  const std::string name = method.empty() ? DefaultMatcherName() : method;
  if (name == "isgm") params.emplace("paths", "8");  // keeps a "paths" the caller set
  return params;
}

void RangingPipelineOptions::Check() const {
  CheckOption(min_depth_m > 0.0, "RangingPipelineOptions.min_depth_m", min_depth_m, "must be > 0");
  CheckOption(max_depth_m > min_depth_m, "RangingPipelineOptions.max_depth_m", max_depth_m,
              "must exceed min_depth_m");
  CheckOption(disparity_margin_px >= 0, "RangingPipelineOptions.disparity_margin_px",
              disparity_margin_px, "must be >= 0");
  CheckOption(model_relative_sigma >= 0.0 && model_relative_sigma < 0.5,
              "RangingPipelineOptions.model_relative_sigma", model_relative_sigma,
              "must be in [0, 0.5)");
  CheckOption(surface_disagreement_weight >= 0.0 && surface_disagreement_weight <= 4.0,
              "RangingPipelineOptions.surface_disagreement_weight", surface_disagreement_weight,
              "must be in [0, 4]");
  surface.Check();
  edges.Check();
  rectify.Check();
}

RangingPipeline::RangingPipeline(const StereoCalibration& calib,
                                 const RangingPipelineOptions& options)
    : options_(options) {
  options_.Check();
  if (options_.input_rectified) {
    rectified_calibration_ = calib;
  } else {
    rectifier_.emplace(calib, options_.rectify);
    rectified_calibration_ = rectifier_->calibration();
  }
  geometry_ = GeometryFromCalibration(rectified_calibration_);
  disparity_range_ = DisparityRangeForDepths(geometry_, options_.min_depth_m, options_.max_depth_m,
                                             options_.disparity_margin_px);
  // Ranging keeps the working range widened by 5 % so that an obstacle right at max_depth_m keeps
  // its pixels despite matching noise; wider would let mismatched background (which the matcher is
  // forced to place at the far end of the range) outvote a poorly matched near obstacle.
  const double near = options_.min_depth_m / 1.05;
  const double far = options_.max_depth_m * 1.05;
  options_.ranging.min_depth_m = near;
  options_.ranging.max_depth_m = far;
  options_.finder.min_depth_m = near;
  options_.finder.max_depth_m = far;
  options_.ranging.Check();
  options_.finder.Check();
  search_range_ = disparity_range_;
  if (options_.search_from_zero) {
    search_range_.min_disparity = 0;
    search_range_.num_disparities = disparity_range_.max_disparity() + 1;
  }
  method_ = options_.method.empty() ? DefaultMatcherName() : options_.method;
  MatcherOptions matcher_options;
  matcher_options.min_disparity = search_range_.min_disparity;
  matcher_options.num_disparities = search_range_.num_disparities;
  matcher_options.threads = options_.threads;
  matcher_options.params = RangingMatcherParams(method_, options_.params);
  matcher_ = CreateMatcher(method_, matcher_options);
}

RangingFrame RangingPipeline::Process(const cv::Mat& left, const cv::Mat& right,
                                      std::optional<cv::Range> rows) const {
  const cv::Size expected = rectified_calibration_.image_size;
  for (const auto& [image, name] : {std::pair{&left, "left"}, std::pair{&right, "right"}}) {
    if (image->empty()) throw InputError(fmt::format("{} image is empty", name));
    if (image->size() != expected) {
      throw InputError(fmt::format("{} image is {}x{} but the calibration is for {}x{}", name,
                                   image->cols, image->rows, expected.width, expected.height));
    }
  }
  RangingFrame frame;
  Stopwatch watch;
  if (rectifier_) {
    rectifier_->Rectify(left, right, &frame.left_rectified, &frame.right_rectified);
  } else {
    frame.left_rectified = left;
    frame.right_rectified = right;
  }
  frame.rectify_ms = watch.ElapsedMs();
  watch.Restart();
  // Band: the requested rows plus a margin for the matcher's windows and path aggregation.
  constexpr int kBandMarginPx = 24;
  const cv::Range band = rows ? cv::Range(std::max(0, rows->start - kBandMarginPx),
                                          std::min(expected.height, rows->end + kBandMarginPx))
                              : cv::Range(0, expected.height);
  LS_CHECK_MSG(band.end > band.start, "empty row band {}..{}", band.start, band.end);
  // OpenCV-style matchers leave the leftmost max_disparity columns without an estimate; obstacles
  // near the robot (large disparity) often sit there. Padding both images on the left by
  // max_disparity columns lets every pixel whose match lies inside the right image be matched; the
  // padding is cut off afterwards.
  const int pad = std::max(0, search_range_.max_disparity());
  cv::Mat left_padded, right_padded;
  cv::copyMakeBorder(frame.left_rectified.rowRange(band), left_padded, 0, 0, pad, 0,
                     cv::BORDER_REPLICATE);
  cv::copyMakeBorder(frame.right_rectified.rowRange(band), right_padded, 0, 0, pad, 0,
                     cv::BORDER_REPLICATE);
  const MatchResult matched = matcher_->Compute(left_padded, right_padded);
  auto unpad = [&](const cv::Mat& padded) {
    cv::Mat full(expected, CV_32FC1, cv::Scalar(kInvalidDisparity));
    padded.colRange(pad, pad + expected.width).copyTo(full.rowRange(band));
    // A match can only lie inside the right image: d <= x.
    for (int y = band.start; y < band.end; ++y) {
      float* d = full.ptr<float>(y);
      for (int x = 0; x < expected.width; ++x) {
        if (IsValidDisparity(d[x]) && d[x] > float(x)) d[x] = kInvalidDisparity;
      }
    }
    return full;
  };
  frame.disparity = unpad(matched.disparity);
  frame.checked_disparity =
      matched.IsSameMapAsDisparity() ? frame.disparity : unpad(matched.checked);
  frame.match_ms = watch.ElapsedMs();
  return frame;
}

std::vector<RangeResult> RangingPipeline::RangeRois(const RangingFrame& frame,
                                                    const std::vector<cv::Rect>& rois) const {
  std::vector<RangeResult> results;
  results.reserve(rois.size());
  for (const cv::Rect& roi : rois)
    results.push_back(RangeObstacle(RangingDisparity(frame), geometry_, roi, options_.ranging));
  for (RangeResult& r : results) {
    RefineSurface(frame, &r);
    AddModelUncertainty(&r);
  }
  return results;
}

std::vector<RangeResult> RangingPipeline::RangeAuto(const RangingFrame& frame) const {
  std::vector<RangeResult> results =
      RangeAllObstacles(RangingDisparity(frame), geometry_, options_.finder, options_.ranging);
  for (RangeResult& r : results) {
    RefineSurface(frame, &r);
    AddModelUncertainty(&r);
  }
  return results;
}

std::vector<Measurement> RangingPipeline::MeasureNearestSurface(const RangingFrame& frame,
                                                                const RangeResult& result) const {
  auto fit = [&](const SurfaceRefinementOptions& surface) {
    return RefineSurfaceDisparity(frame.left_rectified, frame.right_rectified,
                                  result.surface_pixels, result.surface_disparity_px, surface);
  };
  // A correlation highest at an end of its search window, and high enough there to be a
  // surface's: the readings differ by at least the window, and that end is the check.
  auto at_edge = [&](const SurfaceRefinement& f) {
    return f.at_search_edge && f.ncc >= options_.surface.min_ncc;
  };
  auto positive = [&](double d) { return d + geometry_.disparity_offset_px > 0.0; };
  std::vector<Measurement> out;
  const SurfaceRefinement refined = fit(options_.surface);
  const double surface_disagreement = refined.disparity_px - result.surface_disparity_px;
  // The surface's clean pixels: the refined surface plus the matched offset of d_near above the
  // surface's mean (the nearest-point definition kept).
  const double offset = result.disparity_px - result.surface_disparity_px;
  if (refined.ok && positive(refined.disparity_px + offset)) {
    out.push_back({Measurement::Role::kEstimate, "surface", refined.disparity_px + offset,
                   refined.sigma_px, surface_disagreement});
    return out;
  }
  SurfaceRefinement check = refined;
  if (!refined.ok && !at_edge(refined)) {
    // No clean pixels to fit: the silhouette edges, measured on each view.
    const EdgeDisparity edges =
        MeasureEdgeDisparity(frame.left_rectified, frame.right_rectified, result.surface_pixels,
                             result.disparity_px, options_.edges);
    if (edges.ok && positive(edges.disparity_px)) {
      out.push_back({Measurement::Role::kLowerBound, "edges", edges.disparity_px,
                     std::max(edges.sigma_px, options_.ranging.disparity_sigma_floor_px),
                     edges.disparity_px - result.disparity_px});
    }
    // Every pixel of the surface can still be fitted, as a check.
    if (options_.surface.gradient_ratio > 0 || options_.surface.interior_only) {
      SurfaceRefinementOptions all = options_.surface;
      all.gradient_ratio = 0;
      all.interior_only = false;
      check = fit(all);
    }
  }
  if (check.ok || at_edge(check)) {
    out.push_back({Measurement::Role::kCheck, "surface", check.disparity_px, 0.0,
                   check.disparity_px - result.surface_disparity_px});
  }
  return out;
}

void RangingPipeline::RefineSurface(const RangingFrame& frame, RangeResult* result) const {
  if (!result->ok() || !options_.refine_on_images || frame.left_rectified.empty()) return;
  const FusedSurface fused = FuseNearestSurface(result->disparity_px, result->disparity_sigma_px,
                                                MeasureNearestSurface(frame, *result),
                                                options_.surface_disagreement_weight);
  if (!std::isfinite(fused.disagreement_px)) return;  // nothing measured: the matched reading stays
  result->surface_check_px = fused.disagreement_px;
  result->disparity_sigma_px = fused.sigma_px;
  if (fused.adopted) {
    result->refined = true;
    result->refinement = fused.kind;
    result->disparity_px = fused.disparity_px;
    result->distance_m = geometry_.DepthFromDisparity(fused.disparity_px);
  }
  result->sigma_m = geometry_.DepthSigma(result->distance_m, fused.sigma_px);
}

void RangingPipeline::AddModelUncertainty(RangeResult* result) const {
  if (!result->ok()) return;
  const double model = options_.model_relative_sigma * result->distance_m;
  result->sigma_m = std::sqrt(result->sigma_m * result->sigma_m + model * model);
}

}  // namespace linesight
