// Speckle filter of the SGM pipeline: the same result as cv::filterSpeckles (which is serial) with
// the work split over row stripes.

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <vector>

#include "linesight/core/error.h"
#include "linesight/stereo/sgm_stages.h"

namespace linesight::detail {

void FilterSpeckles(cv::Mat* map, int max_speckle_size, int max_diff, int threads) {
  LS_CHECK(map != nullptr && map->type() == CV_16SC1);
  const int width = map->cols, height = map->rows;
  if (width == 0 || height == 0 || max_speckle_size <= 0) return;
  // Pieces: 4-connected pixels != kSgmInvalidFixed whose values differ by at most max_diff (the
  // relation cv::filterSpeckles floods along). A row's piece pixels form horizontal runs; runs of
  // adjacent rows are united when some column of their overlap satisfies the relation. Union-find
  // over the runs whose root is the smallest run index: linking the larger root under the smaller
  // makes the result independent of the order of the unions, so stripes of rows are united in
  // parallel and then joined across the stripe borders.
  struct Run {
    int32_t x0, x1, parent;  // columns [x0, x1) of its row
  };
  const int stripes = std::max(1, std::min(threads, height));
  auto stripe_begin = [&](int stripe) {
    return static_cast<int>(static_cast<int64_t>(height) * stripe / stripes);
  };
  std::vector<std::vector<Run>> stripe_runs(stripes);
  std::vector<int32_t> row_begin(height + 1, 0);  // first run of each row
  auto related = [max_diff](int a, int b) { return std::abs(a - b) <= max_diff; };
  ParallelRanges(stripes, stripes, [&](int begin, int end) {
    for (int stripe = begin; stripe < end; ++stripe) {
      std::vector<Run>& out = stripe_runs[stripe];
      out.clear();
      for (int y = stripe_begin(stripe); y < stripe_begin(stripe + 1); ++y) {
        row_begin[y] = static_cast<int32_t>(out.size());
        const int16_t* d = map->ptr<int16_t>(y);
        for (int x = 0; x < width;) {
          if (d[x] == kSgmInvalidFixed) {
            ++x;
            continue;
          }
          int end_x = x + 1;
          while (end_x < width && d[end_x] != kSgmInvalidFixed && related(d[end_x], d[end_x - 1]))
            ++end_x;
          out.push_back({x, end_x, 0});
          x = end_x;
        }
      }
    }
  });
  std::vector<int32_t> stripe_offset(stripes + 1, 0);
  for (int stripe = 0; stripe < stripes; ++stripe) {
    stripe_offset[stripe + 1] =
        stripe_offset[stripe] + static_cast<int32_t>(stripe_runs[stripe].size());
    for (int y = stripe_begin(stripe); y < stripe_begin(stripe + 1); ++y) {
      row_begin[y] += stripe_offset[stripe];
    }
  }
  const int count = stripe_offset[stripes];
  row_begin[height] = count;
  std::vector<Run> runs(count);
  auto find = [&](int32_t r) {
    while (runs[r].parent != r) {
      runs[r].parent = runs[runs[r].parent].parent;
      r = runs[r].parent;
    }
    return r;
  };
  // Unites the runs of row y with the runs of row y - 1 they touch through a related column.
  auto unite_rows = [&](int y) {
    const int16_t* d = map->ptr<int16_t>(y);
    const int16_t* up = map->ptr<int16_t>(y - 1);
    int above = row_begin[y - 1];
    for (int r = row_begin[y]; r < row_begin[y + 1]; ++r) {
      const int x0 = runs[r].x0, x1 = runs[r].x1;
      while (above < row_begin[y] && runs[above].x1 <= x0) ++above;
      for (int a = above; a < row_begin[y] && runs[a].x0 < x1; ++a) {
        const int from = std::max(x0, runs[a].x0), to = std::min(x1, runs[a].x1);
        int x = from;
        while (x < to && !related(d[x], up[x])) ++x;
        if (x == to) continue;
        const int32_t ra = find(a), rr = find(r);
        if (ra < rr) {
          runs[rr].parent = ra;
        } else if (rr < ra) {
          runs[ra].parent = rr;
        }
      }
    }
  };
  ParallelRanges(stripes, stripes, [&](int begin, int end) {
    for (int stripe = begin; stripe < end; ++stripe) {
      const int offset = stripe_offset[stripe];
      const std::vector<Run>& local = stripe_runs[stripe];
      for (size_t i = 0; i < local.size(); ++i) {
        runs[offset + i] = local[i];
        runs[offset + i].parent = offset + static_cast<int32_t>(i);
      }
      for (int y = stripe_begin(stripe) + 1; y < stripe_begin(stripe + 1); ++y) unite_rows(y);
    }
  });
  for (int stripe = 1; stripe < stripes; ++stripe) unite_rows(stripe_begin(stripe));
  // Every parent index is at most its run's index, so one pass in index order leaves each run
  // pointing at its root; then the piece sizes at the roots.
  std::vector<int32_t> size(count, 0);
  for (int r = 0; r < count; ++r) {
    runs[r].parent = runs[runs[r].parent].parent;
    size[runs[r].parent] += runs[r].x1 - runs[r].x0;
  }
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
