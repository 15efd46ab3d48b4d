// Speckle filter of the SGM pipeline: the same result as cv::filterSpeckles (which is serial) with
// the work split over row stripes.

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <vector>

#include "linesight/core/error.h"
#include "linesight/stereo/run_forest.h"
#include "linesight/stereo/sgm_stages.h"

namespace linesight::detail {

void FilterSpeckles(cv::Mat* map, int max_speckle_size, int max_diff, int threads) {
  LS_CHECK(map != nullptr && map->type() == CV_16SC1);
  const int width = map->cols, height = map->rows;
  if (width == 0 || height == 0 || max_speckle_size <= 0) return;
  // Pieces: 4-connected pixels != kSgmInvalidFixed whose values differ by at most max_diff (the
  // relation cv::filterSpeckles floods along). A row's piece pixels form horizontal runs; runs of
  // adjacent rows belong to one piece when some column of their overlap satisfies the relation.
  auto related = [max_diff](int a, int b) { return std::abs(a - b) <= max_diff; };
  const RunForest forest = BuildRunForest(
      height, threads,
      [&](int y, std::vector<Run>* out) {
        const int16_t* d = map->ptr<int16_t>(y);
        for (int x = 0; x < width;) {
          if (d[x] == kSgmInvalidFixed) {
            ++x;
            continue;
          }
          int end_x = x + 1;
          while (end_x < width && d[end_x] != kSgmInvalidFixed && related(d[end_x], d[end_x - 1]))
            ++end_x;
          out->push_back({x, end_x, 0, 0});
          x = end_x;
        }
      },
      [&](int y, const Run& above, const Run& below) {
        const int16_t* d = map->ptr<int16_t>(y);
        const int16_t* up = map->ptr<int16_t>(y - 1);
        const int to = std::min(above.x1, below.x1);
        for (int x = std::max(above.x0, below.x0); x < to; ++x) {
          if (related(d[x], up[x])) return true;
        }
        return false;
      },
      [&](int n, const auto& fn) { ParallelRanges(n, n, fn); });
  const std::vector<Run>& runs = forest.runs;
  const std::vector<int32_t>& row_begin = forest.row_begin;
  const std::vector<int32_t>& size = forest.size;
  ParallelRanges(height, threads, [&](int begin, int end) {
    for (int y = begin; y < end; ++y) {
      int16_t* d = map->ptr<int16_t>(y);
      for (int r = row_begin[y]; r < row_begin[y + 1]; ++r) {
        if (size[runs[r].parent] <= max_speckle_size) {
          std::fill(d + runs[r].x0, d + runs[r].x1, kSgmInvalidFixed);
        }
      }
    }
  });
}

}  // namespace linesight::detail
