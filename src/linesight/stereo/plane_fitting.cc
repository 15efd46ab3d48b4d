// ISGM plane refinement, stages 2-4 (plane_refinement.h): the segment index, the robust plane fit
// of each segment (RANSAC, then least squares on the inliers; one plane, two or none) and the
// adoption of a neighbour's plane. Compiled with -ffp-contract=off, as the plane kernels are
// (CMakeLists.txt).
#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include <opencv2/core/utility.hpp>

#include "linesight/core/disparity.h"
#include "linesight/core/error.h"
#include "linesight/stereo/plane_refinement.h"

namespace linesight::detail {
namespace {

// SplitMix64: a tiny, well-mixed generator; one stream per segment keeps RANSAC thread-independent.
struct SplitMix64 {
  uint64_t state;
  uint64_t Next() {
    uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  int Below(int n) { return static_cast<int>(Next() % static_cast<uint64_t>(n)); }
};

bool WithinSlant(const DisparityPlane& plane, double max_slant) {
  return std::abs(plane.a) <= max_slant && std::abs(plane.b) <= max_slant;
}

// The RANSAC scoring subsample as separate coordinate arrays, padded for CountPlaneInliers.
struct ScoringSample {
  std::vector<double> x, y, d;
  void Resize(int n) {
    const size_t padded =
        (static_cast<size_t>(n) + kPlanePointPadding - 1) / kPlanePointPadding * kPlanePointPadding;
    x.assign(padded, 0.0);
    y.assign(padded, 0.0);
    d.assign(padded, std::numeric_limits<double>::quiet_NaN());
  }
};

int CountInliers(const ScoringSample& sample, const DisparityPlane& plane, double threshold) {
  return CountPlaneInliers(sample.x.data(), sample.y.data(), sample.d.data(), sample.x.size(),
                           plane, threshold);
}

// The points of one fit in double precision, with each point's terms of the normal equations about
// the fit's origin computed once (every refit adds the same terms of its inliers).
struct FitPoints {
  std::vector<double> x, y, d;
  std::vector<std::array<double, 9>> terms;  // x x, x y, y y, x, y, 1, x d, y d, d (relative)
  void Set(const std::vector<PlanePoint>& points, double ox, double oy) {
    const size_t n = points.size();
    x.resize(n);
    y.resize(n);
    d.resize(n);
    terms.resize(n);
    for (size_t i = 0; i < n; ++i) {
      x[i] = points[i].x;
      y[i] = points[i].y;
      d[i] = points[i].d;
      const double rx = points[i].x - ox, ry = points[i].y - oy, rd = points[i].d;
      terms[i] = {rx * rx, rx * ry, ry * ry, rx, ry, 1.0, rx * rd, ry * rd, rd};
    }
  }
};

// Marks the inliers of `plane`, returns their count and writes the sum of their squared residuals;
// with kAccumulate also their normal equations in the same pass. Branch-free (the inlier test is
// unpredictable on noisy segments): every point adds its terms or 0, which gives the same sums in
// the same order as adding the inliers only.
template <bool kAccumulate>
int MarkInliers(const FitPoints& points, const DisparityPlane& plane, double threshold,
                std::vector<uint8_t>* mask, double* squares,
                PlaneNormalEquations* equations = nullptr) {
  const size_t n = points.x.size();
  mask->resize(n);
  // Local restrict pointers: the byte stores to the mask may alias anything, which otherwise makes
  // the compiler reload every vector's data pointer (from thread-local storage) for each point.
  uint8_t* __restrict marks = mask->data();
  const double* __restrict xs = points.x.data();
  const double* __restrict ys = points.y.data();
  const double* __restrict ds = points.d.data();
  const std::array<double, 9>* __restrict terms = points.terms.data();
  double sums[9] = {};
  int count = 0;
  double sum_squares = 0;
  for (size_t i = 0; i < n; ++i) {
    const double r = plane.At(xs[i], ys[i]) - ds[i];
    const bool inlier = std::abs(r) <= threshold;
    marks[i] = inlier;
    count += inlier;
    sum_squares += inlier ? r * r : 0.0;
    if constexpr (kAccumulate) {
      const std::array<double, 9>& t = terms[i];
      for (int k = 0; k < 9; ++k) sums[k] += inlier ? t[k] : 0.0;
    }
  }
  if constexpr (kAccumulate) {
    PlaneNormalEquations& e = *equations;
    e.sxx = sums[0], e.sxy = sums[1], e.syy = sums[2], e.sx = sums[3], e.sy = sums[4];
    e.n = sums[5], e.sxd = sums[6], e.syd = sums[7], e.sd = sums[8];
  }
  *squares = sum_squares;
  return count;
}

}  // namespace

SegmentIndex BuildSegmentIndex(const cv::Mat& labels, int num_segments) {
  LS_CHECK(labels.type() == CV_32SC1);
  // Counting sort in raster order, over a fixed number of row stripes in parallel: stripe t writes
  // each segment's pixels after those of stripes < t, so the result is the serial one.
  constexpr int kStripes = 4;
  const int rows = labels.rows, cols = labels.cols;
  // Calls row(t, y, labels of row y) for every row of every stripe t, stripes in parallel.
  const auto for_each_stripe_row = [&](const auto& row) {
    cv::parallel_for_(cv::Range(0, kStripes), [&](const cv::Range& range) {
      for (int t = range.start; t < range.end; ++t) {
        for (int y = rows * t / kStripes; y < rows * (t + 1) / kStripes; ++y) {
          row(t, y, labels.ptr<int32_t>(y));
        }
      }
    });
  };
  std::vector<int32_t> counts(static_cast<size_t>(kStripes) * num_segments, 0);
  std::atomic<bool> bad_label{false};
  for_each_stripe_row([&](int t, int, const int32_t* l) {
    int32_t* count = &counts[static_cast<size_t>(t) * num_segments];
    for (int x = 0; x < cols; ++x) {
      if (l[x] < 0 || l[x] >= num_segments) {
        bad_label = true;
        return;
      }
      ++count[l[x]];
    }
  });
  LS_CHECK(!bad_label);
  SegmentIndex index;
  index.offsets.assign(num_segments + 1, 0);
  std::vector<int32_t> cursors(counts.size());
  int32_t total = 0;
  for (int s = 0; s < num_segments; ++s) {
    index.offsets[s] = total;
    for (int t = 0; t < kStripes; ++t) {
      cursors[static_cast<size_t>(t) * num_segments + s] = total;
      total += counts[static_cast<size_t>(t) * num_segments + s];
    }
  }
  index.offsets[num_segments] = total;
  index.pixels.resize(labels.total());
  index.x.resize(labels.total());
  index.y.resize(labels.total());
  for_each_stripe_row([&](int t, int y, const int32_t* l) {
    int32_t* cursor = &cursors[static_cast<size_t>(t) * num_segments];
    for (int x = 0; x < cols; ++x) {
      const int32_t at = cursor[l[x]]++;
      index.pixels[at] = y * cols + x;
      index.x[at] = x;
      index.y[at] = y;
    }
  });
  return index;
}

PlaneNormalEquations AccumulateNormalEquations(const std::vector<PlanePoint>& points,
                                               const std::vector<uint8_t>* selected, double ox,
                                               double oy) {
  PlaneNormalEquations eq;
  for (size_t i = 0; i < points.size(); ++i) {
    if (selected && !(*selected)[i]) continue;
    eq.Add(points[i].x - ox, points[i].y - oy, points[i].d);
  }
  return eq;
}

bool SolvePlane(const PlaneNormalEquations& e, double ox, double oy, DisparityPlane* plane) {
  if (e.n < 3) return false;
  // Symmetric 3x3 system [sxx sxy sx; sxy syy sy; sx sy n] [a b c]' = [sxd syd sd]' by cofactors.
  const double c00 = e.syy * e.n - e.sy * e.sy;
  const double c01 = e.sy * e.sx - e.sxy * e.n;
  const double c02 = e.sxy * e.sy - e.syy * e.sx;
  const double c11 = e.sxx * e.n - e.sx * e.sx;
  const double c12 = e.sxy * e.sx - e.sxx * e.sy;
  const double c22 = e.sxx * e.syy - e.sxy * e.sxy;
  const double det = e.sxx * c00 + e.sxy * c01 + e.sx * c02;
  // Relative test: collinear points make det vanish against the product of the diagonal.
  const double scale = e.sxx * e.syy * e.n;
  if (!(scale > 0) || !(det > 1e-9 * scale)) return false;
  const double a = (c00 * e.sxd + c01 * e.syd + c02 * e.sd) / det;
  const double b = (c01 * e.sxd + c11 * e.syd + c12 * e.sd) / det;
  const double c = (c02 * e.sxd + c12 * e.syd + c22 * e.sd) / det;
  plane->a = a;
  plane->b = b;
  plane->c = c - a * ox - b * oy;
  return std::isfinite(plane->a) && std::isfinite(plane->b) && std::isfinite(plane->c);
}

bool FitPlaneRobust(const std::vector<PlanePoint>& points, const PlaneRefinementOptions& options,
                    uint64_t seed, RobustPlaneFit* fit) {
  const int n = static_cast<int>(points.size());
  if (n < 3) return false;
  const double threshold = options.inlier_threshold;
  double ox = 0, oy = 0;
  for (const PlanePoint& p : points) ox += p.x, oy += p.y;
  ox /= n, oy /= n;

  // Hypotheses are scored on an even subsample of at most ransac_max_points pixels. Scratch is
  // per thread: this runs once or twice for each of thousands of segments per frame.
  thread_local ScoringSample sample;
  thread_local std::vector<float> values;
  const int sample_size = std::min(n, options.ransac_max_points);
  sample.Resize(sample_size);
  for (int i = 0; i < sample_size; ++i) {
    const PlanePoint& p = points[static_cast<size_t>(static_cast<int64_t>(i) * n / sample_size)];
    sample.x[i] = p.x;
    sample.y[i] = p.y;
    sample.d[i] = p.d;
  }

  // The fronto-parallel median is a hypothesis that small or noisy segments often need.
  values.resize(n);
  for (int i = 0; i < n; ++i) values[i] = points[i].d;
  std::nth_element(values.begin(), values.begin() + n / 2, values.end());
  DisparityPlane best{0, 0, values[n / 2]};
  int best_score = CountInliers(sample, best, threshold);

  SplitMix64 rng{seed};
  // A hypothesis replaces the best only with strictly more inliers: once every sampled point is an
  // inlier, none can, and the remaining hypotheses are skipped (the result is the same).
  for (int it = 0; it < options.ransac_iterations && best_score < sample_size; ++it) {
    const int i = rng.Below(n), j = rng.Below(n), k = rng.Below(n);
    if (i == j || j == k || i == k) continue;
    const PlanePoint &p = points[i], &q = points[j], &r = points[k];
    const double ux = q.x - p.x, uy = q.y - p.y, ud = q.d - p.d;
    const double vx = r.x - p.x, vy = r.y - p.y, vd = r.d - p.d;
    const double nx = uy * vd - ud * vy, ny = ud * vx - ux * vd, nz = ux * vy - uy * vx;
    if (std::abs(nz) < 1e-6) continue;  // collinear in the image
    DisparityPlane h;
    h.a = -nx / nz;
    h.b = -ny / nz;
    h.c = p.d - h.a * p.x - h.b * p.y;
    if (!WithinSlant(h, options.max_slant)) continue;
    const int score = CountInliers(sample, h, threshold);
    if (score > best_score) {
      best_score = score;
      best = h;
    }
  }

  // Least squares on the inliers, re-selected after every refit. Once a refit selects the same
  // inliers as the previous one it would reproduce the same plane: the remaining refits are
  // skipped (the result is the same as running them all).
  thread_local std::vector<uint8_t> previous_mask;
  thread_local FitPoints fit_points;
  fit_points.Set(points, ox, oy);
  int count = 0;
  double squares = 0;
  bool marked_best = false;  // inlier_mask, count and squares belong to `best`
  for (int it = 0; it < options.refit_iterations; ++it) {
    PlaneNormalEquations equations;
    count = MarkInliers<true>(fit_points, best, threshold, &fit->inlier_mask, &squares, &equations);
    marked_best = true;
    if (count < 3) break;
    if (it > 0 && fit->inlier_mask == previous_mask) break;
    DisparityPlane refined;
    if (!SolvePlane(equations, ox, oy, &refined) || !WithinSlant(refined, options.max_slant)) {
      break;
    }
    best = refined;
    marked_best = false;
    std::swap(previous_mask, fit->inlier_mask);
  }
  if (!marked_best)
    count = MarkInliers<false>(fit_points, best, threshold, &fit->inlier_mask, &squares);
  fit->plane = best;
  fit->inliers = count;
  fit->residual_rms = count > 0 ? std::sqrt(squares / count) : 0.0;
  return true;
}

namespace {

void CollectValidPoints(const cv::Mat& disparity, const SegmentIndex& index, int segment,
                        std::vector<PlanePoint>* points) {
  points->clear();
  const float* d = disparity.ptr<float>();
  for (int i = index.offsets[segment]; i < index.offsets[segment + 1]; ++i) {
    const int p = index.pixels[i];
    if (IsValidDisparity(d[p])) {
      points->push_back({static_cast<float>(index.x[i]), static_cast<float>(index.y[i]), d[p]});
    }
  }
}

// Mean number of 4-neighbours that are also in the set, over the points of `members` (a subset of
// `points` marked by `in_set`). A surface gives 2..4; scattered mismatches that happen to agree on
// a plane give < 1.
double SetCoherence(const std::vector<PlanePoint>& points, const std::vector<uint8_t>& in_set) {
  int x0 = INT32_MAX, y0 = INT32_MAX, x1 = INT32_MIN, y1 = INT32_MIN, members = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    if (!in_set[i]) continue;
    x0 = std::min(x0, static_cast<int>(points[i].x)),
    x1 = std::max(x1, static_cast<int>(points[i].x));
    y0 = std::min(y0, static_cast<int>(points[i].y)),
    y1 = std::max(y1, static_cast<int>(points[i].y));
    ++members;
  }
  if (members == 0) return 0;
  const int w = x1 - x0 + 3, h = y1 - y0 + 3;  // one pixel of margin on every side
  std::vector<uint8_t> map(static_cast<size_t>(w) * h, 0);
  for (size_t i = 0; i < points.size(); ++i) {
    if (in_set[i])
      map[(static_cast<int>(points[i].y) - y0 + 1) * w + static_cast<int>(points[i].x) - x0 + 1] =
          1;
  }
  int64_t links = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    if (!in_set[i]) continue;
    const int at =
        (static_cast<int>(points[i].y) - y0 + 1) * w + static_cast<int>(points[i].x) - x0 + 1;
    links += map[at - 1] + map[at + 1] + map[at - w] + map[at + w];
  }
  return static_cast<double>(links) / members;
}

bool Acceptable(const RobustPlaneFit& fit, const PlaneRefinementOptions& options) {
  return fit.residual_rms <= options.max_residual_rms && WithinSlant(fit.plane, options.max_slant);
}

SegmentModel FitOneSegment(const std::vector<PlanePoint>& points, int segment_size, int segment,
                           const PlaneRefinementOptions& options) {
  SegmentModel model;
  model.valid = static_cast<int>(points.size());
  const int needed = std::max(
      options.min_support, static_cast<int>(std::ceil(options.min_support_ratio * segment_size)));
  if (model.valid < needed) return model;
  const uint64_t seed = 0x5EED0000ull + 2ull * static_cast<uint64_t>(segment);
  RobustPlaneFit first;
  if (!FitPlaneRobust(points, options, seed, &first) || !Acceptable(first, options)) return model;

  // The pixels the dominant plane leaves out may form a second surface: a depth edge inside the
  // segment. Then both planes are kept so the smaller surface is not flattened onto the larger one.
  const int rest_count = model.valid - first.inliers;
  if (options.two_plane_fallback && first.inliers >= options.min_support &&
      rest_count >= options.min_support) {
    std::vector<PlanePoint> rest;
    rest.reserve(rest_count);
    for (size_t i = 0; i < points.size(); ++i) {
      if (!first.inlier_mask[i]) rest.push_back(points[i]);
    }
    RobustPlaneFit second;
    if (FitPlaneRobust(rest, options, seed + 1, &second) && Acceptable(second, options) &&
        second.inliers >= options.min_support && 2 * second.inliers >= rest_count &&
        second.inliers >= options.min_second_plane_ratio * model.valid &&
        first.inliers + second.inliers >= options.min_inlier_ratio * model.valid &&
        SetCoherence(rest, second.inlier_mask) >= options.min_surface_coherence) {
      model.kind = SegmentModelKind::kTwoPlanes;
      model.planes = {first.plane, second.plane};
      model.inliers = first.inliers + second.inliers;
      return model;
    }
  }
  if (first.inliers >= options.min_inlier_ratio * model.valid) {
    model.kind = SegmentModelKind::kPlane;
    model.planes[0] = first.plane;
    model.inliers = first.inliers;
  }
  return model;
}

}  // namespace

std::vector<SegmentModel> FitSegmentPlanes(const cv::Mat& disparity, const SegmentIndex& index,
                                           const PlaneRefinementOptions& options) {
  LS_CHECK(disparity.type() == CV_32FC1 && disparity.isContinuous());
  const int segments = static_cast<int>(index.offsets.size()) - 1;
  std::vector<SegmentModel> models(segments);
  cv::parallel_for_(cv::Range(0, segments), [&](const cv::Range& range) {
    std::vector<PlanePoint> points;
    for (int s = range.start; s < range.end; ++s) {
      CollectValidPoints(disparity, index, s, &points);
      models[s] = FitOneSegment(points, index.Size(s), s, options);
    }
  });
  return models;
}

namespace {

// Segments 4-adjacent to `segment`, sorted.
void AdjacentSegments(const cv::Mat& labels, const SegmentIndex& index, int segment,
                      std::vector<int32_t>* neighbours) {
  const int width = labels.cols, height = labels.rows;
  const int32_t* label = labels.ptr<int32_t>();
  neighbours->clear();
  for (int i = index.offsets[segment]; i < index.offsets[segment + 1]; ++i) {
    const int p = index.pixels[i];
    const int x = index.x[i], y = index.y[i];
    const int around[4] = {x > 0 ? label[p - 1] : segment, x + 1 < width ? label[p + 1] : segment,
                           y > 0 ? label[p - width] : segment,
                           y + 1 < height ? label[p + width] : segment};
    for (int n : around) {
      if (n != segment &&
          std::find(neighbours->begin(), neighbours->end(), n) == neighbours->end()) {
        neighbours->push_back(n);
      }
    }
  }
  std::sort(neighbours->begin(), neighbours->end());
}

}  // namespace

void AdoptNeighbourPlanes(const cv::Mat& disparity, const cv::Mat& labels,
                          const SegmentIndex& index, const PlaneRefinementOptions& options,
                          std::vector<SegmentModel>* models) {
  const int segments = static_cast<int>(models->size());
  LS_CHECK(labels.type() == CV_32SC1 && labels.isContinuous());
  // Candidates come from the models as fitted (not from other adoptions), so the order does not
  // matter.
  const std::vector<SegmentModel> fitted = *models;
  cv::parallel_for_(cv::Range(0, segments), [&](const cv::Range& range) {
    std::vector<PlanePoint> points;
    std::vector<int32_t> neighbours;
    for (int s = range.start; s < range.end; ++s) {
      if (fitted[s].kind != SegmentModelKind::kNone || fitted[s].valid < 3) continue;
      CollectValidPoints(disparity, index, s, &points);
      AdjacentSegments(labels, index, s, &neighbours);  // sorted: ties go to the smaller label
      int best_score = 0;
      DisparityPlane best;
      for (int n : neighbours) {
        const SegmentModel& neighbour = fitted[n];
        const int planes = neighbour.kind == SegmentModelKind::kPlane       ? 1
                           : neighbour.kind == SegmentModelKind::kTwoPlanes ? 2
                                                                            : 0;
        for (int k = 0; k < planes; ++k) {
          const DisparityPlane& plane = neighbour.planes[k];
          int score = 0;
          for (const PlanePoint& p : points) {
            score += std::abs(plane.At(p.x, p.y) - p.d) <= options.inlier_threshold;
          }
          if (score > best_score) {
            best_score = score;
            best = plane;
          }
        }
      }
      if (best_score >= 3 && best_score >= options.min_inlier_ratio * points.size()) {
        SegmentModel& model = (*models)[s];
        model.kind = SegmentModelKind::kAdopted;
        model.planes[0] = best;
        model.inliers = best_score;
      }
    }
  });
}

}  // namespace linesight::detail
