// Occlusion filling of a disparity map: an invalid pixel takes the background (the smaller) of the
// nearest valid disparities on its row, after Hirschmueller's occlusion filling. Used by the ISGM
// plane refinement (stage 6 of plane_refinement.h, where the map must end up dense) and by the gc
// matcher after its left-right check (GraphCutOptions::fill_occlusions).
#pragma once

#include <cstdint>

#include <opencv2/core.hpp>

namespace linesight::detail {

struct BackgroundFillOptions {
  // Rows without any valid pixel copy the nearest row that has one (the upper one on a tie; an
  // image without any valid pixel becomes 0), so the result is dense. Off: they stay invalid
  // (every pixel of such a row becomes kInvalidDisparity).
  bool fill_empty_rows = true;
  // Rows in parallel on OpenCV's thread pool; off: on the calling thread. The result is the same.
  bool parallel = true;
};

// Fills every invalid pixel of `disparity` (CV_32FC1) with the smaller of the nearest valid
// disparities left and right on its row (one side if only one exists); rows without any valid pixel
// as options.fill_empty_rows says. Returns the number of pixels that received a value (with
// fill_empty_rows, every pixel of a copied or zeroed row counts).
int64_t FillFromBackground(cv::Mat* disparity, const BackgroundFillOptions& options = {});

}  // namespace linesight::detail
