// OpenCV's own matchers (StereoBM, StereoSGBM in its four modes) behind our interface: the
// baselines every linesight method is measured against. Factories and parameter docs of the
// registry entries "bm", "sgbm" and "sgbm-wls" (matcher.cc). They run on OpenCV's thread pool,
// sized per call (ScopedOpenCvThreads); one object is not safe to call from several threads at
// once (OpenCV's matchers keep their buffers). MatchResult::checked is the disparity itself.
#pragma once

#include <memory>
#include <vector>

#include "linesight/stereo/matcher.h"

namespace linesight {

// OpenCV StereoBM; its --param keys: OpenCvBlockMatcherParamDocs().
std::unique_ptr<StereoMatcher> CreateOpenCvBlockMatcher(const MatcherOptions& options,
                                                        MatcherParams& params);
std::vector<MatcherParamDoc> OpenCvBlockMatcherParamDocs();

// OpenCV StereoSGBM; its --param keys, with OpenCV's stereo_match sample settings for a grey image
// as defaults: OpenCvSgbmParamDocs().
std::unique_ptr<StereoMatcher> CreateOpenCvSgbm(const MatcherOptions& options,
                                                MatcherParams& params);
std::vector<MatcherParamDoc> OpenCvSgbmParamDocs();

// SGBM (same parameters) + ximgproc DisparityWLSFilter with the right-view matcher and confidence;
// its --param keys: OpenCvSgbmWlsParamDocs() (the sgbm keys plus lambda and sigma).
std::unique_ptr<StereoMatcher> CreateOpenCvSgbmWls(const MatcherOptions& options,
                                                   MatcherParams& params);
std::vector<MatcherParamDoc> OpenCvSgbmWlsParamDocs();

}  // namespace linesight
