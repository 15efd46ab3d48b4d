// Connected pieces of an image as a union-find over the horizontal runs of its rows, computed over
// row stripes in parallel. Shared by the superpixel connectivity pass and the SGM speckle filter.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

namespace linesight::detail {

// Columns [x0, x1) of one row; `label` is the caller's (e.g. the superpixel label), `parent` the
// union-find link (after BuildRunForest: the piece's root).
struct Run {
  int32_t x0, x1, label, parent;
};

struct RunForest {
  std::vector<Run> runs;           // raster order
  std::vector<int32_t> row_begin;  // height + 1: runs of row y are [row_begin[y], row_begin[y + 1])
  std::vector<int32_t> size;       // pixels of the piece, at its root run
};

// extract(y, std::vector<Run>* out) appends the runs of row y in increasing x (parent unused);
// touches(y, above, below) says whether run `above` of row y - 1 and the overlapping run `below` of
// row y belong to one piece; parallel(n, fn) runs fn(begin, end) over parts of [0, n).
// Every piece's root is its smallest run index, i.e. its first run in raster order: linking the
// larger root under the smaller gives that whatever the order of the unions, so the stripes are
// united in parallel and then joined across the stripe borders (the result does not depend on
// `stripes`).
template <class Extract, class Touches, class Parallel>
RunForest BuildRunForest(int height, int stripes, Extract&& extract, Touches&& touches,
                         Parallel&& parallel) {
  stripes = std::max(1, std::min(stripes, height));
  auto stripe_begin = [&](int stripe) {
    return static_cast<int>(static_cast<int64_t>(height) * stripe / stripes);
  };
  RunForest forest;
  std::vector<int32_t>& row_begin = forest.row_begin;
  row_begin.assign(height + 1, 0);
  // The runs of each stripe, row_begin counted within the stripe; then concatenated.
  std::vector<std::vector<Run>> stripe_runs(stripes);
  parallel(stripes, [&](int begin, int end) {
    for (int stripe = begin; stripe < end; ++stripe) {
      std::vector<Run>& out = stripe_runs[stripe];
      for (int y = stripe_begin(stripe); y < stripe_begin(stripe + 1); ++y) {
        row_begin[y] = static_cast<int32_t>(out.size());
        extract(y, &out);
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
  std::vector<Run>& runs = forest.runs;
  runs.resize(count);
  auto find = [&](int32_t r) {
    while (runs[r].parent != r) {
      runs[r].parent = runs[runs[r].parent].parent;
      r = runs[r].parent;
    }
    return r;
  };
  // Unites the runs of row y with the overlapping runs of row y - 1 that `touches` accepts.
  auto unite_rows = [&](int y) {
    int above = row_begin[y - 1];
    for (int r = row_begin[y]; r < row_begin[y + 1]; ++r) {
      while (above < row_begin[y] && runs[above].x1 <= runs[r].x0) ++above;
      for (int a = above; a < row_begin[y] && runs[a].x0 < runs[r].x1; ++a) {
        if (!touches(y, runs[a], runs[r])) continue;
        const int32_t ra = find(a), rr = find(r);
        if (ra < rr) {
          runs[rr].parent = ra;
        } else if (rr < ra) {
          runs[ra].parent = rr;
        }
      }
    }
  };
  parallel(stripes, [&](int begin, int end) {
    for (int stripe = begin; stripe < end; ++stripe) {
      const int offset = stripe_offset[stripe];
      const std::vector<Run>& local = stripe_runs[stripe];
      for (size_t i = 0; i < local.size(); ++i) {
        runs[offset + i] = local[i];
        runs[offset + i].parent = offset + static_cast<int32_t>(i);
      }
      // Rows of this stripe only: the unions touch runs of this stripe only.
      for (int y = stripe_begin(stripe) + 1; y < stripe_begin(stripe + 1); ++y) unite_rows(y);
    }
  });
  for (int stripe = 1; stripe < stripes; ++stripe) unite_rows(stripe_begin(stripe));
  // Every parent index is at most its run's index, so one pass in index order leaves each run
  // pointing at its root; then the piece sizes at the roots.
  forest.size.assign(count, 0);
  for (int r = 0; r < count; ++r) {
    runs[r].parent = runs[runs[r].parent].parent;
    forest.size[runs[r].parent] += runs[r].x1 - runs[r].x0;
  }
  return forest;
}

}  // namespace linesight::detail
