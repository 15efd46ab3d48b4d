#include "linesight/stereo/disparity_fill.h"

#include <algorithm>
#include <vector>

#include <opencv2/core/utility.hpp>

#include "linesight/core/disparity.h"
#include "linesight/core/error.h"

namespace linesight::detail {

int64_t FillFromBackground(cv::Mat* disparity, const BackgroundFillOptions& options) {
  LS_CHECK(disparity->type() == CV_32FC1);
  const int width = disparity->cols, height = disparity->rows;
  std::vector<uint8_t> row_has_valid(height, 0);
  std::vector<int64_t> row_filled(height, 0);
  // Rows are independent here.
  const auto fill_rows = [&](const cv::Range& range) {
    std::vector<float> from_left(width);
    for (int y = range.start; y < range.end; ++y) {
      float* d = disparity->ptr<float>(y);
      float last = kInvalidDisparity;
      for (int x = 0; x < width; ++x) {
        if (IsValidDisparity(d[x])) last = d[x];
        from_left[x] = last;
      }
      if (!IsValidDisparity(last)) {
        if (!options.fill_empty_rows) std::fill(d, d + width, kInvalidDisparity);
        continue;
      }
      row_has_valid[y] = 1;
      float next = kInvalidDisparity;
      for (int x = width - 1; x >= 0; --x) {
        if (IsValidDisparity(d[x])) {
          next = d[x];
          continue;
        }
        // +inf on a missing side makes min() pick the other side.
        d[x] = std::min(from_left[x], next);
        ++row_filled[y];
      }
    }
  };
  if (options.parallel) {
    cv::parallel_for_(cv::Range(0, height), fill_rows);
  } else {
    fill_rows(cv::Range(0, height));
  }
  int64_t filled = 0;
  for (const int64_t n : row_filled) filled += n;
  if (!options.fill_empty_rows) return filled;
  // Rows without any valid pixel copy the nearest row that had one (the upper one on a tie).
  int nearest_above = -1;
  for (int y = 0; y < height; ++y) {
    if (row_has_valid[y]) {
      nearest_above = y;
      continue;
    }
    int nearest_below = -1;
    for (int yy = y + 1; yy < height; ++yy) {
      if (row_has_valid[yy]) {
        nearest_below = yy;
        break;
      }
    }
    int source = nearest_above;
    if (source < 0 || (nearest_below >= 0 && nearest_below - y < y - nearest_above)) {
      source = nearest_below;
    }
    if (source < 0) {
      disparity->row(y).setTo(0.0f);
    } else {
      disparity->row(source).copyTo(disparity->row(y));
    }
    filled += width;
  }
  return filled;
}

}  // namespace linesight::detail
