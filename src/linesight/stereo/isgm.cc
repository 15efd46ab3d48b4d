#include "linesight/stereo/isgm.h"

#include <algorithm>

#include <fmt/format.h>
#include <opencv2/core/utility.hpp>

#include "linesight/core/disparity.h"
#include "linesight/core/error.h"
#include "linesight/core/scoped_threads.h"

namespace linesight {

SgmOptions IsgmDefaultSgmOptions() {
  SgmOptions o;
  o.census_width = 7;
  o.census_height = 5;
  o.p1 = 14;
  o.p2 = 100;
  o.p2_gradient_alpha = 4;
  o.num_paths = 4;  // see isgm.h: as accurate as 8 after the refinement, 1.2x faster
  return o;
}

PlaneRefinementOptions IsgmDefaultRefinementOptions() {
  PlaneRefinementOptions o;
  o.superpixels.region_size = 13;
  o.superpixels.compactness = 10;
  o.inlier_threshold = 0.5;
  o.outlier_threshold = 1.0;
  return o;
}

void IsgmOptions::Check() const {
  sgm.Check();
  refinement.Check();
}

nlohmann::json IsgmOptions::ToJson() const {
  return {{"sgm", sgm.ToJson()}, {"refinement", refinement.ToJson()}};
}

IsgmMatcher::IsgmMatcher(const IsgmOptions& options) : options_(options), sgm_(options.sgm) {
  options_.Check();
}

IsgmResult IsgmMatcher::ComputeDetailed(const cv::Mat& left, const cv::Mat& right) {
  IsgmResult result;
  result.sgm = sgm_.ComputeDetailed(left, right);
  Refine(left, right, result.sgm.disparity, &result);
  return result;
}

MatchResult IsgmMatcher::Compute(const cv::Mat& left, const cv::Mat& right) {
  // SgmMatcher::Compute reuses its intermediate maps between frames; the refinement needs only the
  // disparity, the same map as ComputeDetailed's sgm.disparity.
  IsgmResult result;
  const cv::Mat sgm_disparity = sgm_.Compute(left, right).disparity;
  Refine(left, right, sgm_disparity, &result);
  return {result.disparity, sgm_disparity};
}

void IsgmMatcher::Refine(const cv::Mat& left, const cv::Mat& right, const cv::Mat& sgm_disparity,
                         IsgmResult* result_out) const {
  IsgmResult& result = *result_out;
  // The refinement runs on OpenCV's thread pool, sized from the options for this call only (like
  // the OpenCV matchers); its result does not depend on the thread count.
  const ScopedOpenCvThreads threads(options_.sgm.threads);
  // Superpixels on the grey image: as accurate as 8-bit Lab on every benchmark set we measured
  // (better on ETH3D, KITTI, Middlebury 2005/2014) at a third of the distance computations.
  const cv::Mat left_for_segments = ToGray8(left), right_for_segments = ToGray8(right);
  result.disparity = RefineDisparityWithPlanes(sgm_disparity, left_for_segments, right_for_segments,
                                               options_.refinement, &result.refinement);
  // Planes are clamped to the range of SGM's valid values; if SGM found nothing, the zeros of the
  // fill are moved into the search range.
  const float lo = static_cast<float>(options_.sgm.min_disparity);
  const float hi =
      static_cast<float>(options_.sgm.min_disparity + options_.sgm.num_disparities - 1);
  for (int y = 0; y < result.disparity.rows; ++y) {
    float* d = result.disparity.ptr<float>(y);
    for (int x = 0; x < result.disparity.cols; ++x) d[x] = std::clamp(d[x], lo, hi);
  }
}

nlohmann::json IsgmMatcher::Settings() const {
  nlohmann::json settings = options_.ToJson();
  settings["method"] = "isgm";
  settings["simd_target"] = SgmSimdTarget();
  return settings;
}

IsgmOptions ReadIsgmOptions(const MatcherOptions& options, MatcherParams& params) {
  IsgmOptions o;
  // isgm's SGM stage starts from its own tuned defaults; --param keys override them.
  o.sgm = ReadSgmOptions(options, params, IsgmDefaultSgmOptions());
  PlaneRefinementOptions& r = o.refinement;
  r.superpixels.region_size = params.GetInt("superpixel_size", r.superpixels.region_size);
  r.superpixels.compactness = params.GetDouble("superpixel_compactness", r.superpixels.compactness);
  r.inlier_threshold = params.GetDouble("plane_inlier", r.inlier_threshold);
  r.outlier_threshold = params.GetDouble("plane_outlier", r.outlier_threshold);
  r.min_inlier_ratio = params.GetDouble("plane_min_inlier_ratio", r.min_inlier_ratio);
  r.max_slant = params.GetDouble("plane_max_slant", r.max_slant);
  r.two_plane_fallback = params.GetBool("two_planes", r.two_plane_fallback);
  r.adopt_neighbour_planes = params.GetBool("adopt_planes", r.adopt_neighbour_planes);
  r.snap_inliers = params.GetBool("snap_inliers", r.snap_inliers);
  r.photometric_radius = params.GetInt("photometric_radius", r.photometric_radius);
  r.median_size = params.GetInt("final_median", r.median_size);
  o.Check();
  return o;
}

std::vector<MatcherParamDoc> IsgmParamDocs() {
  std::vector<MatcherParamDoc> docs = SgmParamDocs(IsgmDefaultSgmOptions());
  const PlaneRefinementOptions r = IsgmDefaultRefinementOptions();
  docs.insert(
      docs.end(),
      {
          {"superpixel_size", "int", ParamDefault(r.superpixels.region_size),
           "superpixel grid spacing, about their side (px, >= 4)"},
          {"superpixel_compactness", "number", ParamDefault(r.superpixels.compactness),
           "grey-level difference that counts as much as one superpixel_size of distance (> 0)"},
          {"plane_inlier", "number", ParamDefault(r.inlier_threshold),
           "distance from a plane (px) within which a disparity supports it (> 0)"},
          {"plane_outlier", "number", ParamDefault(r.outlier_threshold),
           "valid disparities farther than this from their segment's plane are replaced (px, >= "
           "plane_inlier)"},
          {"plane_min_inlier_ratio", "number", ParamDefault(r.min_inlier_ratio),
           "fraction of a segment's valid disparities its plane(s) must explain (0..1]"},
          {"plane_max_slant", "number", ParamDefault(r.max_slant),
           "largest plane slope |a|, |b| (px of disparity per px)"},
          {"two_planes", "bool", ParamDefault(r.two_plane_fallback),
           "a segment one plane cannot explain may take two (a depth edge inside it)"},
          {"adopt_planes", "bool", ParamDefault(r.adopt_neighbour_planes),
           "segments without a plane try their neighbours' planes"},
          {"snap_inliers", "bool", ParamDefault(r.snap_inliers),
           "also replace valid disparities near the plane by the plane value"},
          {"photometric_radius", "int", ParamDefault(r.photometric_radius),
           "two-plane segments pick a pixel's plane by image agreement over a (2r+1)^2 window "
           "(px); 0 = off"},
          {"final_median", "int", ParamDefault(r.median_size),
           "median window over the final dense map: 0 (off), 3 or 5"},
      });
  return docs;
}

std::unique_ptr<StereoMatcher> CreateIsgmMatcher(const MatcherOptions& options,
                                                 MatcherParams& params) {
  return std::make_unique<IsgmMatcher>(ReadIsgmOptions(options, params));
}

}  // namespace linesight
