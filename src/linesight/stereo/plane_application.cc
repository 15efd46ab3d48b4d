// ISGM plane refinement, stage 5 (plane_refinement.h): outliers and holes of every segment with a
// model take its plane value; in two-plane segments the surface that encloses them, chosen by the
// disparities or, with the right image, by photometry. Compiled with -ffp-contract=off, as the
// plane kernels are (CMakeLists.txt).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include <opencv2/core/utility.hpp>

#include "linesight/core/disparity.h"
#include "linesight/core/error.h"
#include "linesight/stereo/plane_refinement.h"

namespace linesight::detail {

namespace {

// A segment with two surfaces: valid disparities near one plane stay (or snap to it); mismatches
// and holes take the plane of the surface that encloses them on their row inside the segment (both
// nearest surface pixels left and right agree, or only one side exists); between two different
// surfaces (an occlusion) they take the background, i.e. the smaller plane value.
void ApplyTwoPlanes(const SegmentIndex& index, int segment, const SegmentModel& model,
                    const PlaneRefinementOptions& options, const SegmentPhotometry* photometry,
                    float min_value, float max_value, float* d, int64_t* filled,
                    int64_t* replaced) {
  constexpr int8_t kHole = -1;
  const int begin = index.offsets[segment], end = index.offsets[segment + 1];
  std::vector<int8_t> surface(end - begin);
  auto plane_value = [&](int k, int i) {
    return std::clamp(static_cast<float>(model.planes[k].At(index.x[i], index.y[i])), min_value,
                      max_value);
  };
  for (int i = begin; i < end; ++i) {
    const int p = index.pixels[i];
    int8_t& s = surface[i - begin];
    s = kHole;
    if (!IsValidDisparity(d[p])) continue;
    const float p0 = plane_value(0, i), p1 = plane_value(1, i);
    const float r0 = std::abs(d[p] - p0), r1 = std::abs(d[p] - p1);
    if (photometry) {
      // The images decide which surface a matched pixel is on: a window restricted to the segment
      // does not straddle the depth edge the way the matcher's window did (foreground fattening).
      const float c0 = photometry->Cost(index.x[i], index.y[i], segment, model.planes[0]);
      const float c1 = photometry->Cost(index.x[i], index.y[i], segment, model.planes[1]);
      s = c0 < c1 || (c0 == c1 && p0 <= p1) ? 0 : 1;
      const float plane = s == 0 ? p0 : p1;
      if ((s == 0 ? r0 : r1) > options.outlier_threshold) {
        d[p] = plane;
        ++*replaced;
      } else if (options.snap_inliers) {
        d[p] = plane;
      }
      continue;
    }
    if (std::min(r0, r1) > options.outlier_threshold) {
      d[p] = kInvalidDisparity;  // a mismatch on neither surface
      continue;
    }
    s = r0 <= r1 ? 0 : 1;
    if (options.snap_inliers) d[p] = s == 0 ? p0 : p1;
  }
  // Pixels of one row are consecutive in the index (raster order).
  std::vector<int8_t> left_surface;
  for (int row_begin = begin; row_begin < end;) {
    const int y = index.y[row_begin];
    int row_end = row_begin;
    while (row_end < end && index.y[row_end] == y) ++row_end;
    left_surface.assign(row_end - row_begin, kHole);
    int8_t last = kHole;
    for (int i = row_begin; i < row_end; ++i) {
      if (surface[i - begin] != kHole) last = surface[i - begin];
      left_surface[i - row_begin] = last;
    }
    int8_t next = kHole;
    for (int i = row_end - 1; i >= row_begin; --i) {
      const int8_t s = surface[i - begin];
      if (s != kHole) {
        next = s;
        continue;
      }
      const int8_t left = left_surface[i - row_begin];
      if (left == kHole && next == kHole) continue;  // left to the background fill
      const int p = index.pixels[i];
      if (left == kHole || next == kHole || left == next) {
        d[p] = plane_value(left == kHole ? next : left, i);
      } else {
        d[p] = std::min(plane_value(0, i), plane_value(1, i));
      }
      ++*filled;
    }
    row_begin = row_end;
  }
}

}  // namespace

float SegmentPhotometry::Cost(int x, int y, int segment, const DisparityPlane& plane) const {
  const int channels = left.channels();
  const int width = left.cols, height = left.rows;
  const int32_t* label = labels.ptr<int32_t>();
  float total = 0;
  int count = 0;
  for (int wy = std::max(0, y - radius); wy <= std::min(height - 1, y + radius); ++wy) {
    const uint8_t* l = left.ptr<uint8_t>(wy);
    const uint8_t* r = right.ptr<uint8_t>(wy);
    for (int wx = std::max(0, x - radius); wx <= std::min(width - 1, x + radius); ++wx) {
      if (label[wy * width + wx] != segment) continue;
      ++count;
      const float xr = static_cast<float>(wx - plane.At(wx, wy));
      if (!(xr >= 0) || xr > width - 1) {
        total += static_cast<float>(truncation * channels);
        continue;
      }
      const int x0 = std::min(static_cast<int>(xr), std::max(width - 2, 0));
      const int x1 = std::min(x0 + 1, width - 1);
      const float t = xr - static_cast<float>(x0);
      for (int ch = 0; ch < channels; ++ch) {
        const float right_value = (1 - t) * r[x0 * channels + ch] + t * r[x1 * channels + ch];
        total +=
            std::min(std::abs(l[wx * channels + ch] - right_value), static_cast<float>(truncation));
      }
    }
  }
  return count > 0 ? total / count : 0.0f;
}

void ApplySegmentPlanes(const SegmentIndex& index, const std::vector<SegmentModel>& models,
                        const PlaneRefinementOptions& options, const SegmentPhotometry* photometry,
                        float min_value, float max_value, cv::Mat* disparity,
                        PlaneRefinementStats* stats) {
  LS_CHECK(disparity->type() == CV_32FC1 && disparity->isContinuous());
  const int segments = static_cast<int>(models.size());
  float* d = disparity->ptr<float>();
  std::vector<int64_t> replaced(segments, 0), filled(segments, 0);
  cv::parallel_for_(cv::Range(0, segments), [&](const cv::Range& range) {
    for (int s = range.start; s < range.end; ++s) {
      const SegmentModel& model = models[s];
      if (model.kind == SegmentModelKind::kNone) continue;
      const bool two = model.kind == SegmentModelKind::kTwoPlanes;
      for (int i = index.offsets[s]; !two && i < index.offsets[s + 1]; ++i) {
        const int p = index.pixels[i];
        const double x = index.x[i], y = index.y[i];
        const float value = d[p];
        const bool valid = IsValidDisparity(value);
        const float plane =
            std::clamp(static_cast<float>(model.planes[0].At(x, y)), min_value, max_value);
        if (!valid) {
          d[p] = plane;
          ++filled[s];
        } else if (std::abs(value - plane) > options.outlier_threshold) {
          d[p] = plane;
          ++replaced[s];
        } else if (options.snap_inliers) {
          d[p] = plane;
        }
      }
      if (two) {
        ApplyTwoPlanes(index, s, model, options, photometry, min_value, max_value, d, &filled[s],
                       &replaced[s]);
      }
    }
  });
  if (stats) {
    for (int s = 0; s < segments; ++s) {
      stats->outliers_replaced += replaced[s];
      stats->holes_filled_by_plane += filled[s];
    }
  }
}

}  // namespace linesight::detail
