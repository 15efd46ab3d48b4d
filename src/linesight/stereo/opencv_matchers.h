// OpenCV's own matchers (StereoBM, StereoSGBM in its four modes) behind our interface: the
// baselines every linesight method is measured against.
#pragma once

#include <memory>

#include "linesight/stereo/matcher.h"

namespace linesight {

// Parameters (--param key=value): block (odd, 5..255, default 15), uniqueness (default 15),
// texture (default 10), speckle_window (default 100), speckle_range (default 2 px),
// prefilter_cap (default 31).
std::unique_ptr<StereoMatcher> CreateOpenCvBlockMatcher(const MatcherOptions& options,
                                                        MatcherParams& params);

// Parameters: mode = sgbm | hh | 3way | hh4 (default 3way), block (odd, default 5), p1 (default
// 8*block^2), p2 (default 32*block^2), uniqueness (default 10), speckle_window (default 100),
// speckle_range (default 2), disp12_max_diff (default 1), prefilter_cap (default 63). Defaults are
// OpenCV's stereo_match sample settings for a grey image.
std::unique_ptr<StereoMatcher> CreateOpenCvSgbm(const MatcherOptions& options,
                                                MatcherParams& params);

// SGBM (same parameters as above) + ximgproc DisparityWLSFilter with the right-view matcher and
// confidence. Extra parameters: lambda (default 8000), sigma (colour sigma, default 1.5).
std::unique_ptr<StereoMatcher> CreateOpenCvSgbmWls(const MatcherOptions& options,
                                                   MatcherParams& params);

}  // namespace linesight
