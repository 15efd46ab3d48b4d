// Options and driver of the ISGM plane refinement (RefineDisparityWithPlanes) and its final median;
// the stages live in plane_fitting.cc, plane_application.cc and disparity_fill.cc.
#include "linesight/stereo/plane_refinement.h"

#include <algorithm>
#include <limits>
#include <optional>
#include <vector>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "linesight/core/disparity.h"
#include "linesight/core/error.h"
#include "linesight/core/timer.h"
#include "linesight/stereo/disparity_fill.h"

namespace linesight {

void PlaneRefinementOptions::Check() const {
  superpixels.Check();
  CheckOption(inlier_threshold > 0, "PlaneRefinementOptions.inlier_threshold", inlier_threshold,
              "must be > 0 px");
  CheckOption(outlier_threshold >= inlier_threshold, "PlaneRefinementOptions.outlier_threshold",
              outlier_threshold, "must be >= inlier_threshold");
  CheckOption(min_support >= 3, "PlaneRefinementOptions.min_support", min_support, "must be >= 3");
  CheckOption(min_support_ratio >= 0 && min_support_ratio <= 1,
              "PlaneRefinementOptions.min_support_ratio", min_support_ratio, "must be in [0, 1]");
  CheckOption(min_inlier_ratio > 0 && min_inlier_ratio <= 1,
              "PlaneRefinementOptions.min_inlier_ratio", min_inlier_ratio, "must be in (0, 1]");
  CheckOption(max_residual_rms > 0, "PlaneRefinementOptions.max_residual_rms", max_residual_rms,
              "must be > 0 px");
  CheckOption(max_slant > 0, "PlaneRefinementOptions.max_slant", max_slant, "must be > 0 px/px");
  CheckOption(min_surface_coherence >= 0, "PlaneRefinementOptions.min_surface_coherence",
              min_surface_coherence, "must be >= 0");
  CheckOption(min_second_plane_ratio >= 0 && min_second_plane_ratio <= 1,
              "PlaneRefinementOptions.min_second_plane_ratio", min_second_plane_ratio,
              "must be in [0, 1]");
  CheckOption(median_size == 0 || median_size == 1 || median_size == 3 || median_size == 5,
              "PlaneRefinementOptions.median_size", median_size, "must be 0, 1, 3 or 5 px");
  CheckOption(photometric_radius >= 0, "PlaneRefinementOptions.photometric_radius",
              photometric_radius, "must be >= 0 px (0 = off)");
  CheckOption(photometric_truncation >= 1, "PlaneRefinementOptions.photometric_truncation",
              photometric_truncation, "must be >= 1 grey level");
  CheckOption(ransac_iterations >= 0, "PlaneRefinementOptions.ransac_iterations", ransac_iterations,
              "must be >= 0");
  CheckOption(ransac_max_points >= 8, "PlaneRefinementOptions.ransac_max_points", ransac_max_points,
              "must be >= 8");
  CheckOption(refit_iterations >= 1, "PlaneRefinementOptions.refit_iterations", refit_iterations,
              "must be >= 1");
}

nlohmann::json PlaneRefinementOptions::ToJson() const {
  return {{"superpixel_size", superpixels.region_size},
          {"superpixel_compactness", superpixels.compactness},
          {"superpixel_iterations", superpixels.iterations},
          {"superpixel_min_size_ratio", superpixels.min_size_ratio},
          {"inlier_threshold", inlier_threshold},
          {"outlier_threshold", outlier_threshold},
          {"min_support", min_support},
          {"min_support_ratio", min_support_ratio},
          {"min_inlier_ratio", min_inlier_ratio},
          {"max_residual_rms", max_residual_rms},
          {"max_slant", max_slant},
          {"ransac_iterations", ransac_iterations},
          {"ransac_max_points", ransac_max_points},
          {"refit_iterations", refit_iterations},
          {"two_plane_fallback", two_plane_fallback},
          {"min_surface_coherence", min_surface_coherence},
          {"min_second_plane_ratio", min_second_plane_ratio},
          {"photometric_radius", photometric_radius},
          {"photometric_truncation", photometric_truncation},
          {"adopt_neighbour_planes", adopt_neighbour_planes},
          {"snap_inliers", snap_inliers},
          {"median_size", median_size}};
}

nlohmann::json PlaneRefinementStats::ToJson() const {
  return {{"segments", segments},
          {"planar_segments", planar_segments},
          {"two_plane_segments", two_plane_segments},
          {"adopted_segments", adopted_segments},
          {"unexplained_segments", unexplained_segments},
          {"outliers_replaced", outliers_replaced},
          {"holes_filled_by_plane", holes_filled_by_plane},
          {"holes_filled_from_background", holes_filled_from_background},
          {"superpixel_ms", superpixel_ms},
          {"plane_fit_ms", plane_fit_ms},
          {"fill_ms", fill_ms}};
}

namespace detail {

cv::Mat MedianBlurStripes(const cv::Mat& src, int ksize) {
  const int context = ksize / 2;
  // Stripes of at least 8 kernel heights, so the context rows stay a small overhead.
  const int stripes = std::clamp(std::min(cv::getNumThreads(), src.rows / (8 * ksize)), 1, 64);
  if (stripes == 1) {
    cv::Mat dst;
    cv::medianBlur(src, dst, ksize);
    return dst;
  }
  cv::Mat dst(src.size(), src.type());
  cv::parallel_for_(cv::Range(0, stripes), [&](const cv::Range& range) {
    for (int s = range.start; s < range.end; ++s) {
      const int y0 = src.rows * s / stripes, y1 = src.rows * (s + 1) / stripes;
      const int c0 = std::max(0, y0 - context), c1 = std::min(src.rows, y1 + context);
      // A copy, so that the filter sees exactly these rows (and replicates only the image's own
      // first and last rows, as on the whole image).
      const cv::Mat part = src.rowRange(c0, c1).clone();
      cv::Mat filtered;
      cv::medianBlur(part, filtered, ksize);
      filtered.rowRange(y0 - c0, y1 - c0).copyTo(dst.rowRange(y0, y1));
    }
  });
  return dst;
}

}  // namespace detail

cv::Mat RefineDisparityWithPlanes(const cv::Mat& disparity, const cv::Mat& left_image,
                                  const PlaneRefinementOptions& options,
                                  PlaneRefinementStats* stats) {
  return RefineDisparityWithPlanes(disparity, left_image, cv::Mat(), options, stats);
}

cv::Mat RefineDisparityWithPlanes(const cv::Mat& disparity, const cv::Mat& left_image,
                                  const cv::Mat& right_image, const PlaneRefinementOptions& options,
                                  PlaneRefinementStats* stats) {
  options.Check();
  if (disparity.type() != CV_32FC1) {
    throw InputError(
        fmt::format("plane refinement needs a CV_32FC1 disparity, got type {}", disparity.type()));
  }
  if (!right_image.empty() &&
      (right_image.size() != left_image.size() || right_image.type() != left_image.type())) {
    throw InputError(fmt::format("right image is {}x{} type {} but the left image is {}x{} type {}",
                                 right_image.cols, right_image.rows, right_image.type(),
                                 left_image.cols, left_image.rows, left_image.type()));
  }
  if (disparity.size() != left_image.size()) {
    throw InputError(fmt::format("disparity is {}x{} but the left image is {}x{}", disparity.cols,
                                 disparity.rows, left_image.cols, left_image.rows));
  }
  PlaneRefinementStats local;
  PlaneRefinementStats& st = stats ? *stats : local;
  st = PlaneRefinementStats();
  cv::Mat out = disparity.clone();  // continuous

  // Range of the valid disparities, per row in parallel (min / max are exact in any order).
  std::vector<float> row_min(out.rows, std::numeric_limits<float>::max()),
      row_max(out.rows, std::numeric_limits<float>::lowest());
  cv::parallel_for_(cv::Range(0, out.rows), [&](const cv::Range& range) {
    for (int y = range.start; y < range.end; ++y) {
      const float* d = out.ptr<float>(y);
      float lo = row_min[y], hi = row_max[y];
      for (int x = 0; x < out.cols; ++x) {
        if (!IsValidDisparity(d[x])) continue;
        lo = std::min(lo, d[x]);
        hi = std::max(hi, d[x]);
      }
      row_min[y] = lo;
      row_max[y] = hi;
    }
  });
  const float min_value = *std::min_element(row_min.begin(), row_min.end());
  const float max_value = *std::max_element(row_max.begin(), row_max.end());
  if (min_value > max_value) {
    out.setTo(0.0f);
    st.holes_filled_from_background = static_cast<int64_t>(out.total());
    return out;
  }

  Stopwatch watch;
  int segments = 0;
  const cv::Mat labels = SegmentSuperpixels(left_image, options.superpixels, &segments);
  st.segments = segments;
  st.superpixel_ms = watch.ElapsedMs();

  watch.Restart();
  const detail::SegmentIndex index = detail::BuildSegmentIndex(labels, segments);
  std::vector<detail::SegmentModel> models = detail::FitSegmentPlanes(out, index, options);
  if (options.adopt_neighbour_planes)
    detail::AdoptNeighbourPlanes(out, labels, index, options, &models);
  for (const detail::SegmentModel& m : models) {
    st.planar_segments += m.kind == detail::SegmentModelKind::kPlane;
    st.two_plane_segments += m.kind == detail::SegmentModelKind::kTwoPlanes;
    st.adopted_segments += m.kind == detail::SegmentModelKind::kAdopted;
    st.unexplained_segments += m.kind == detail::SegmentModelKind::kNone;
  }
  st.plane_fit_ms = watch.ElapsedMs();

  watch.Restart();
  std::optional<detail::SegmentPhotometry> photometry;
  if (!right_image.empty() && options.photometric_radius > 0) {
    photometry.emplace();
    photometry->left = left_image;
    photometry->right = right_image;
    photometry->labels = labels;
    photometry->radius = options.photometric_radius;
    photometry->truncation = options.photometric_truncation;
  }
  detail::ApplySegmentPlanes(index, models, options, photometry ? &*photometry : nullptr, min_value,
                             max_value, &out, &st);
  st.holes_filled_from_background = detail::FillFromBackground(&out);
  if (options.median_size > 1) {
    // A last median over the dense map removes the streaks of row-wise filling and isolated
    // remaining mismatches (Hirschmueller 2008 smooths the same way).
    out = detail::MedianBlurStripes(out, options.median_size);
  }
  st.fill_ms = watch.ElapsedMs();
  return out;
}

}  // namespace linesight