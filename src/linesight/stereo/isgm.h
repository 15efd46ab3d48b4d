// The `isgm` method: our SGM (sgm.h) whose disparity map is refined by robust least-squares planes
// inside superpixels of the left image (plane_refinement.h), giving a 100 % dense map:
//
//   SgmMatcher::ComputeDetailed → SegmentSuperpixels → FitSegmentPlanes → AdoptNeighbourPlanes
//   → ApplySegmentPlanes (outliers and holes take the plane) → FillFromBackground (occlusions)
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "linesight/stereo/matcher.h"
#include "linesight/stereo/plane_refinement.h"
#include "linesight/stereo/sgm.h"

namespace linesight {

// SGM settings that suit the plane refinement (one set for every scene, chosen over all benchmark
// sets, see docs/algorithms/isgm.md): a 7x5 census window (less foreground fattening at depth edges
// than 9x7), P1 = 14, P2 = 100, a strongly gradient-adapted P2 (alpha 4) and 4 paths; everything
// else is SgmOptions' default. 4 paths rather than 8: after the refinement they are as accurate on
// the benchmarks (`eval stereo`, headline error 8 -> 4 paths: ETH3D 4.69 -> 4.47, KITTI 4.17
// -> 3.95, Middlebury 2001/2003 3.28 -> 3.24, 2005/2006 3.89 -> 3.66, 2014 3.66 -> 3.99, Scene Flow
// 40.77 -> 41.79) and the aggregation, half of isgm's time, costs two thirds (`linesight bench`:
// 1.2x the frame rate). The ranging chain keeps 8 paths (RangingMatcherParams in
// ranging/pipeline.h): on small obstacle fronts they are measurably better.
SgmOptions IsgmDefaultSgmOptions();

// Refinement settings of isgm (chosen with IsgmDefaultSgmOptions): superpixels of 13 px with
// compactness 10, planes scored with a 0.5 px inlier band (a 1 px band lets a slanted plane run
// through a 2 px step and the fattened band beside it) and valid disparities more than 1 px from
// their segment's plane replaced; everything else is PlaneRefinementOptions' default.
PlaneRefinementOptions IsgmDefaultRefinementOptions();

struct IsgmOptions {
  SgmOptions sgm = IsgmDefaultSgmOptions();  // the matcher whose output is refined
  PlaneRefinementOptions refinement = IsgmDefaultRefinementOptions();  // superpixels, planes, fill

  void Check() const;
  nlohmann::json ToJson() const;
};

struct IsgmResult {
  cv::Mat disparity;  // CV_32FC1, dense (every pixel finite), within the disparity range
  SgmResult sgm;      // the SGM stage's products (sgm.disparity = before refinement)
  PlaneRefinementStats refinement;
};

// The SGM stage runs its own std::threads, the refinement OpenCV's pool sized for the call
// (ScopedOpenCvThreads). Not thread-safe (the SGM scratch buffers are reused); use one matcher per
// thread.
class IsgmMatcher final : public StereoMatcher {
 public:
  explicit IsgmMatcher(const IsgmOptions& options);

  std::string Name() const override { return "isgm"; }
  // disparity = the refined dense map, checked = the SGM stage's map (IsgmResult's disparity and
  // sgm.disparity, without SGM's detailed maps).
  MatchResult Compute(const cv::Mat& left, const cv::Mat& right) override;
  nlohmann::json Settings() const override;

  IsgmResult ComputeDetailed(const cv::Mat& left, const cv::Mat& right);
  const IsgmOptions& options() const { return options_; }

 private:
  // The refinement of SGM's disparity into result->disparity and result->refinement.
  void Refine(const cv::Mat& left, const cv::Mat& right, const cv::Mat& sgm_disparity,
              IsgmResult* result) const;

  IsgmOptions options_;
  SgmMatcher sgm_;
};

// Reads IsgmOptions from MatcherOptions and the --param keys of IsgmParamDocs.
IsgmOptions ReadIsgmOptions(const MatcherOptions& options, MatcherParams& params);

// The --param keys ReadIsgmOptions reads: every sgm key (SgmParamDocs with the defaults of
// IsgmDefaultSgmOptions) plus the refinement's (defaults from IsgmDefaultRefinementOptions).
std::vector<MatcherParamDoc> IsgmParamDocs();

// Factory of the registry entry "isgm" (matcher.cc).
std::unique_ptr<StereoMatcher> CreateIsgmMatcher(const MatcherOptions& options,
                                                 MatcherParams& params);

}  // namespace linesight
