#include "linesight/ranging/thin_structures.h"

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "linesight/core/disparity.h"
#include "linesight/core/error.h"
#include "linesight/ranging/row_runs.h"

namespace linesight {

DepthBands::DepthBands(const StereoGeometry& geometry, double min_depth_m, double max_depth_m,
                       double band_width)
    : offset(geometry.disparity_offset_px),
      d_low(geometry.DisparityFromDepth(max_depth_m)),
      d_high(geometry.DisparityFromDepth(min_depth_m)),
      log_low(std::log(d_low + offset)),
      width(band_width),
      count(int(std::ceil((std::log(d_high + offset) - log_low) / width)) + 1) {}

cv::Mat DepthBands::Map(const cv::Mat& disparity) const {
  cv::Mat band_of(disparity.size(), CV_32S, cv::Scalar(-1));
  for (int y = 0; y < disparity.rows; ++y) {
    const float* d = disparity.ptr<float>(y);
    int* b = band_of.ptr<int>(y);
    for (int x = 0; x < disparity.cols; ++x) {
      if (IsValidDisparity(d[x]) && d[x] >= d_low && d[x] <= d_high) b[x] = Of(d[x]);
    }
  }
  return band_of;
}

void ThinStructureOptions::Check() const {
  CheckOption(min_width_m > 0.0, "ThinStructureOptions.min_width_m", min_width_m, "must be > 0");
  CheckOption(min_width_px >= 0.0 && min_width_px <= 64.0, "ThinStructureOptions.min_width_px",
              min_width_px, "must be in [0, 64]");
  CheckOption(depth_band_relative > 0.0 && depth_band_relative <= 0.5,
              "ThinStructureOptions.depth_band_relative", depth_band_relative,
              "must be in (0, 0.5]");
  CheckOption(min_depth_m > 0.0, "ThinStructureOptions.min_depth_m", min_depth_m, "must be > 0");
  CheckOption(max_depth_m > min_depth_m, "ThinStructureOptions.max_depth_m", max_depth_m,
              "must exceed min_depth_m");
}

namespace {

// Distances saturate at 255, so a run's half-length is at most 254: elements of at most this many
// rows and columns.
constexpr size_t kMaxRuns = 509;

// Up to this size OpenCV's own morphology (SIMD over the element's pixels) is the faster; both give
// the same pixels.
constexpr int kSmallEllipse = 11;

// Half-width of each row of OpenCV's n x n MORPH_ELLIPSE structuring element (symmetric about its
// centre, each row one run; -1 for an empty row).
std::vector<int> EllipseRows(int n) {
  LS_CHECK(n >= 1 && n % 2 == 1);
  const cv::Mat k = cv::getStructuringElement(cv::MORPH_ELLIPSE, {n, n});
  std::vector<int> rows;
  for (int y = 0; y < n; ++y) {
    const std::uint8_t* row = k.ptr<std::uint8_t>(y);
    int first = n, last = -1;
    for (int x = 0; x < n; ++x) {
      if (row[x]) {
        first = std::min(first, x);
        last = std::max(last, x);
      }
    }
    LS_CHECK(last < 0 || (first + last == n - 1 && cv::countNonZero(k.row(y)) == last - first + 1));
    rows.push_back(last < 0 ? -1 : (last - first) / 2);
  }
  return rows;
}

// Dilation of `src` (0 / 255) by an element given as centred row runs (half-width of each row,
// -1 for an empty row; the element is convex, so each of its columns is a centred run too):
// out(y, x) is set when some column dx of the element has a set pixel of column x + dx of `src`
// within its half-height of row y. Each pixel's vertical distance to the nearest set pixel of its
// column is computed once (two passes down and up the image, a vector of pixels at a time); then
// each element column costs one compare a pixel, instead of one per element pixel.
void DilateRows(const cv::Mat& src, const std::vector<int>& rows, cv::Mat* out, EllipseScratch* s) {
  LS_CHECK(rows.size() % 2 == 1 && rows.size() <= kMaxRuns);
  constexpr int kFar = 255;
  const int half_height = int(rows.size()) / 2;
  const int half_width = std::max(0, *std::max_element(rows.begin(), rows.end()));
  // Half-height of each column dx = -half_width..half_width of the element.
  std::vector<int> column(size_t(2 * half_width + 1), -1);
  for (int j = 0; j < int(rows.size()); ++j) {
    for (int dx = -rows[size_t(j)]; dx <= rows[size_t(j)]; ++dx) {
      int& h = column[size_t(dx + half_width)];
      h = std::max(h, std::abs(j - half_height));
    }
  }
  for (int dx = -half_width; dx <= half_width; ++dx) {  // each column one centred run
    const int h = column[size_t(dx + half_width)];
    for (int dy = -half_height; dy <= half_height; ++dy) {
      LS_CHECK((std::abs(dy) <= h) == (std::abs(dx) <= rows[size_t(dy + half_height)]));
    }
  }
  // Rows are worked on in whole blocks of kBlock bytes and padded by half_width far pixels on
  // both sides, so the kernel reads every shifted row without bounds checks or a scalar tail.
  constexpr int kBlock = 64;
  const int cols = src.cols, height = src.rows, wide = (cols + kBlock - 1) / kBlock * kBlock;
  const int pad = half_width;
  s->near.create(height, wide + 2 * pad, CV_8U);
  for (int y = 0; y < height; ++y) {
    const std::uint8_t* in = src.ptr<std::uint8_t>(y);
    std::uint8_t* d = s->near.ptr<std::uint8_t>(y);
    const std::uint8_t* above = y > 0 ? s->near.ptr<std::uint8_t>(y - 1) : nullptr;
    std::fill(d, d + pad, std::uint8_t(kFar));
    std::fill(d + pad + cols, d + wide + 2 * pad, std::uint8_t(kFar));
    std::uint8_t* __restrict v = d + pad;
    if (above == nullptr) {
      for (int x = 0; x < cols; ++x) v[x] = in[x] ? 0 : kFar;
    } else {
      const std::uint8_t* __restrict a = above + pad;
      for (int x = 0; x < cols; ++x) {
        v[x] = in[x] ? 0 : std::uint8_t(std::min(int(a[x]) + 1, kFar));
      }
    }
  }
  for (int y = height - 2; y >= 0; --y) {
    std::uint8_t* __restrict v = s->near.ptr<std::uint8_t>(y) + pad;
    const std::uint8_t* __restrict b = s->near.ptr<std::uint8_t>(y + 1) + pad;
    for (int x = 0; x < cols; ++x) {
      v[x] = std::uint8_t(std::min(int(v[x]), std::min(int(b[x]) + 1, kFar)));
    }
  }
  s->wide.create(height, wide, CV_8U);
  std::vector<const std::uint8_t*> near(column.size());
  std::vector<std::uint8_t> heights(column.size());
  for (int y = 0; y < height; ++y) {
    const std::uint8_t* row = s->near.ptr<std::uint8_t>(y) + pad;
    int count = 0;
    for (int dx = -half_width; dx <= half_width; ++dx) {
      const int h = column[size_t(dx + half_width)];
      if (h < 0) continue;
      near[size_t(count)] = row + dx;
      heights[size_t(count)] = std::uint8_t(h);
      ++count;
    }
    detail::OrRowRuns(near.data(), heights.data(), count, wide, s->wide.ptr<std::uint8_t>(y));
  }
  s->wide.colRange(0, cols).copyTo(*out);
}

// OpenCV's 5x5 chamfer distance (cv::distanceTransform with DIST_L2, DIST_MASK_5): steps of
// 1, 1.4 and 2.1969 px along the axes, the diagonals and the knight's moves, in 16.16 fixed point.
constexpr int kChamferShift = 16;
const int kChamferAxis = cvRound(1.0f * (1 << kChamferShift));
const int kChamferDiagonal = cvRound(1.4f * (1 << kChamferShift));
const int kChamferKnight = cvRound(2.1969f * (1 << kChamferShift));

// Half-width of each row of the ball {v : chamfer(v) < radius} (rows -R..R, each one centred
// run): a pixel is nearer than `radius` to a set pixel exactly when it lies in the set's
// dilation by this ball. The chamfer length of an offset is the cheapest sum of steps reaching
// it (all steps point into its quadrant), and is compared as the float OpenCV returns.
std::vector<int> ChamferBallRows(double radius) {
  const int reach = int(std::ceil(radius)) + 1;
  std::vector<std::int64_t> length(size_t((reach + 1) * (reach + 1)));
  auto at = [&](int x, int y) -> std::int64_t& { return length[size_t(y * (reach + 1) + x)]; };
  const struct {
    int dx, dy, weight;
  } steps[] = {{1, 0, kChamferAxis},
               {0, 1, kChamferAxis},
               {1, 1, kChamferDiagonal},
               {2, 1, kChamferKnight},
               {1, 2, kChamferKnight}};
  for (int y = 0; y <= reach; ++y) {
    for (int x = 0; x <= reach; ++x) {
      std::int64_t best = x == 0 && y == 0 ? 0 : std::numeric_limits<std::int64_t>::max();
      for (const auto& st : steps) {
        if (st.dx <= x && st.dy <= y) best = std::min(best, at(x - st.dx, y - st.dy) + st.weight);
      }
      at(x, y) = best;
    }
  }
  const float scale = 1.f / float(1 << kChamferShift);
  auto inside = [&](int x, int y) { return double(float(at(x, y)) * scale) < radius; };
  std::vector<int> half(size_t(2 * reach + 1), -1);
  for (int y = 0; y <= reach; ++y) {
    int w = -1;
    while (w + 1 <= reach && inside(w + 1, y)) ++w;
    // One run per row: nothing beyond the first offset outside the ball is inside again.
    for (int x = w + 1; x <= reach; ++x) LS_CHECK(!inside(x, y));
    half[size_t(reach + y)] = half[size_t(reach - y)] = w;
  }
  LS_CHECK(half.front() < 0 && half.back() < 0);  // the ball ends inside `reach`
  return half;
}

}  // namespace

cv::Mat SurfaceBands(const DepthBands& bands, const cv::Mat& disparity) {
  cv::Mat band_of = bands.Map(disparity);
  for (int y = 0; y < disparity.rows; ++y) {
    const float* d = disparity.ptr<float>(y);
    int* b = band_of.ptr<int>(y);
    for (int x = 0; x < disparity.cols; ++x) {
      if (b[x] < 0 && !(IsValidDisparity(d[x]) && d[x] < bands.d_low)) b[x] = kNoSurface;
    }
  }
  return band_of;
}

void NearerThan(const cv::Mat& off, double radius, cv::Mat* out, EllipseScratch* scratch) {
  LS_CHECK(off.type() == CV_8UC1 && radius > 0.0);
  std::vector<int> rows = ChamferBallRows(radius);
  // Trim the empty rows at both ends (the element stays centred).
  size_t trim = 0;
  while (rows[trim] < 0 && rows[rows.size() - 1 - trim] < 0) ++trim;
  rows = std::vector<int>(rows.begin() + std::ptrdiff_t(trim), rows.end() - std::ptrdiff_t(trim));
  if (rows.size() > kMaxRuns) {
    // Beyond the runs' saturated distances: the distance transform itself.
    cv::Mat clear, distance;
    cv::compare(off, 0, clear, cv::CMP_EQ);
    cv::distanceTransform(clear, distance, cv::DIST_L2, cv::DIST_MASK_5);
    cv::compare(distance, radius, *out, cv::CMP_LT);
    return;
  }
  if (int(rows.size()) > kSmallEllipse) {
    DilateRows(off, rows, out, scratch);
    return;
  }
  {
    const int n = int(rows.size());
    cv::Mat element(n, n, CV_8U, cv::Scalar(0));
    for (int y = 0; y < n; ++y) {
      if (rows[size_t(y)] >= 0) {
        element.row(y).colRange(n / 2 - rows[size_t(y)], n / 2 + rows[size_t(y)] + 1).setTo(1);
      }
    }
    cv::dilate(off, *out, element);
  }
}

void DilateEllipse(const cv::Mat& src, int n, cv::Mat* out, EllipseScratch* scratch) {
  LS_CHECK(src.type() == CV_8UC1);
  if (n <= kSmallEllipse) {
    cv::dilate(src, *out, cv::getStructuringElement(cv::MORPH_ELLIPSE, {n, n}));
    return;
  }
  DilateRows(src, EllipseRows(n), out, scratch);
}

void ErodeEllipse(const cv::Mat& src, int n, cv::Mat* out, EllipseScratch* scratch) {
  LS_CHECK(src.type() == CV_8UC1);
  if (n <= kSmallEllipse) {
    cv::erode(src, *out, cv::getStructuringElement(cv::MORPH_ELLIPSE, {n, n}));
    return;
  }
  // The erosion is the complement of the complement's dilation (the element is symmetric);
  // outside the image the source counts as set, so its complement as clear.
  cv::compare(src, 0, scratch->complement, cv::CMP_EQ);
  DilateRows(scratch->complement, EllipseRows(n), out, scratch);
  cv::bitwise_not(*out, *out);
}

void CloseEllipse(const cv::Mat& src, int n, cv::Mat* out, EllipseScratch* scratch) {
  DilateEllipse(src, n, &scratch->dilated, scratch);
  ErodeEllipse(scratch->dilated, n, out, scratch);
}

cv::Mat BodyMask(const cv::Mat& disparity, const StereoGeometry& geometry, const cv::Rect& region,
                 const ThinStructureOptions& options, bool seeds_only, const BandRegion& needed) {
  options.Check();
  LS_CHECK(disparity.type() == CV_32FC1);
  const cv::Rect image(0, 0, disparity.cols, disparity.rows);
  LS_CHECK((region & image) == region);
  const DepthBands depth_bands(geometry, options.min_depth_m, options.max_depth_m,
                               options.depth_band_relative);
  const double offset = depth_bands.offset;
  const double d_low = depth_bands.d_low, d_high = depth_bands.d_high;
  const int bands = depth_bands.count;
  auto radius_of_band = [&](int k) {
    const double d = depth_bands.CentreDisparity(k);
    return 0.5 * std::max(options.min_width_px,
                          options.min_width_m * geometry.focal_px / geometry.DepthFromDisparity(d));
  };
  // Work on the region plus a margin as wide as the largest body radius that occurs in it.
  double max_radius = 0.0;
  const cv::Mat inner = disparity(region);
  for (int y = 0; y < inner.rows; ++y) {
    const float* d = inner.ptr<float>(y);
    for (int x = 0; x < inner.cols; ++x) {
      if (IsValidDisparity(d[x]) && d[x] >= d_low && d[x] <= d_high) {
        max_radius = std::max(
            max_radius, 0.5 * std::max(options.min_width_px, options.min_width_m * (d[x] + offset) /
                                                                 geometry.baseline_m));
      }
    }
  }
  const int margin = int(std::ceil(max_radius)) + 2;
  const cv::Rect outer =
      (region + cv::Size(2 * margin, 2 * margin) - cv::Point(margin, margin)) & image;
  const cv::Mat view = disparity(outer);
  const cv::Mat band_of = SurfaceBands(depth_bands, view);
  // Each band's bounding box: each band is worked on inside the box of its surface plus a margin,
  // not on the whole view, with the same result pixel for pixel (the reference test checks this).
  // The closing adds pixels only within its disc's radius of the surface, so a margin of that
  // radius plus two pixels leaves a ring of pixels off the surface inside the crop: every distance
  // from a pixel of the box to the nearest pixel off the surface is then measured inside the crop,
  // and the growth from the seeds is cut to the closed surface, which is inside the crop too.
  struct Bounds {
    int x0 = std::numeric_limits<int>::max(), y0 = x0, x1 = -1, y1 = -1;
  };
  // Bands -1..bands - 1 (-1: beyond the far end, part of band 0's surface), offset by one.
  std::vector<Bounds> bounds(static_cast<size_t>(bands + 1));
  // The bands present in each kTile x kTile tile (a bit each): a band is worked on around the
  // clusters of tiles that hold its surface, not over the box of all of them, where a few stray
  // matches at its depth would make that box most of the image.
  constexpr int kTile = 16;
  const int tiles_x = (band_of.cols + kTile - 1) / kTile,
            tiles_y = (band_of.rows + kTile - 1) / kTile;
  const int words = (bands + 63) / 64;
  std::vector<std::uint64_t> tile_bands(size_t(tiles_x) * size_t(tiles_y) * size_t(words));
  // Band 0's surface (bands -1..1 in the loop below) holds the pixels beyond the far end too.
  std::vector<std::uint8_t> tile_unbanded(size_t(tiles_x) * size_t(tiles_y));
  for (int y = 0; y < band_of.rows; ++y) {
    const int* b = band_of.ptr<int>(y);
    std::uint64_t* tile_row = tile_bands.data() + size_t(y / kTile) * size_t(tiles_x * words);
    for (int x = 0; x < band_of.cols; ++x) {
      if (b[x] == kNoSurface) continue;
      Bounds& k = bounds[size_t(b[x] + 1)];
      k.x0 = std::min(k.x0, x);
      k.x1 = std::max(k.x1, x);
      k.y0 = std::min(k.y0, y);
      k.y1 = std::max(k.y1, y);
      if (b[x] < 0) {
        tile_unbanded[size_t(y / kTile) * size_t(tiles_x) + size_t(x / kTile)] = 1;
        continue;
      }
      tile_row[size_t((x / kTile) * words + b[x] / 64)] |= std::uint64_t{1} << (b[x] % 64);
    }
  }
  auto tile_holds = [&](int tx, int ty, int k) {
    if (k == -1) return tile_unbanded[size_t(ty) * size_t(tiles_x) + size_t(tx)] != 0;
    if (k < 0 || k >= bands) return false;
    const size_t word =
        (size_t(ty) * size_t(tiles_x) + size_t(tx)) * size_t(words) + size_t(k / 64);
    return (tile_bands[word] >> (k % 64) & 1) != 0;
  };
  std::vector<cv::Rect> box_of(bounds.size());  // band k's at k + 1
  for (size_t k = 0; k < bounds.size(); ++k) {
    if (bounds[k].x1 >= 0) {
      box_of[k] = cv::Rect(cv::Point(bounds[k].x0, bounds[k].y0),
                           cv::Point(bounds[k].x1 + 1, bounds[k].y1 + 1));
    }
  }
  const cv::Rect whole(0, 0, view.cols, view.rows);
  // The image border is not a surface edge: it clips bodies, it does not make them thin.
  const bool at_border =
      outer.x == 0 || outer.y == 0 || outer.br().x == image.width || outer.br().y == image.height;
  cv::Mat body(view.size(), CV_8U, cv::Scalar(0));
  cv::Mat surface, padded, off, near_off, seeds, grown, in_band, marked, joined, labels;
  EllipseScratch scratch;
  for (int k = 0; k < bands; ++k) {
    if (box_of[size_t(k + 1)].empty()) continue;
    cv::Rect box = box_of[size_t(k + 1)] | box_of[size_t(k)];
    if (k + 1 < bands) box |= box_of[size_t(k + 2)];
    const double radius = radius_of_band(k);
    const int r = int(std::ceil(radius));
    // Matching leaves small holes inside bodies; a hole must not make a body look thin. Closing
    // with a disc of the body radius fills holes narrower than that radius without widening a
    // conductor.
    const int close = std::max(3, int(std::round(radius)) | 1);
    const int reach = close / 2 + 2;
    cv::Rect limit = (box + cv::Size(2 * reach, 2 * reach) - cv::Point(reach, reach)) & whole;
    // A pixel's result depends on the pixels within this margin: a body pixel grows from seeds
    // within r, a seed needs the closed surface within its ball, and the closing needs the surface
    // within twice its element's half-width.
    const int m = 2 * r + 1 + 2 * (close / 2) + 2;
    if (needed) {
      // Only the needed pixels of bands k - 1..k + 1 must come out right.
      const double d_from =
          std::max(d_low, std::exp(depth_bands.log_low + (k - 1) * depth_bands.width) - offset);
      const double d_to =
          std::min(d_high, std::exp(depth_bands.log_low + (k + 2) * depth_bands.width) - offset);
      const cv::Rect need = needed(d_from, d_to) - outer.tl();
      if ((need & whole).empty()) continue;
      limit &= need + cv::Size(2 * m, 2 * m) - cv::Point(m, m);
      if (limit.empty()) continue;
    }
    // Clusters of the tiles inside `limit` that hold the surface (bands k - 1..k + 1): tiles whose
    // margins would overlap join one cluster. Each cluster's box comes out right when worked on
    // with the margin around it; every surface pixel lies in some cluster's box.
    marked.create(tiles_y, tiles_x, CV_8U);
    marked.setTo(0);
    for (int ty = limit.y / kTile; ty <= (limit.br().y - 1) / kTile; ++ty) {
      for (int tx = limit.x / kTile; tx <= (limit.br().x - 1) / kTile; ++tx) {
        if (tile_holds(tx, ty, k - 1) || tile_holds(tx, ty, k) || tile_holds(tx, ty, k + 1)) {
          marked.at<std::uint8_t>(ty, tx) = 255;
        }
      }
    }
    std::vector<cv::Rect> clusters;
    const int join = (m + kTile - 1) / kTile;
    cv::dilate(marked, joined,
               cv::getStructuringElement(cv::MORPH_RECT, {2 * join + 1, 2 * join + 1}));
    const int count = cv::connectedComponents(joined, labels, 8, CV_32S);
    clusters.resize(size_t(std::max(0, count - 1)));
    for (int ty = 0; ty < tiles_y; ++ty) {
      for (int tx = 0; tx < tiles_x; ++tx) {
        if (marked.at<std::uint8_t>(ty, tx) == 0) continue;
        clusters[size_t(labels.at<int>(ty, tx) - 1)] |=
            cv::Rect(tx * kTile, ty * kTile, kTile, kTile);
      }
    }
    for (const cv::Rect& tiles : clusters) {
      // The closing adds pixels up to its half-width away from the surface, so the cluster's
      // results reach that far beyond its tiles.
      const int grow = close / 2;
      const cv::Rect exact = (tiles + cv::Size(2 * grow, 2 * grow) - cv::Point(grow, grow)) & limit;
      if (exact.empty()) continue;
      const cv::Rect crop = (exact + cv::Size(2 * m, 2 * m) - cv::Point(m, m)) & limit;
      cv::inRange(band_of(crop), k - 1, k + 1, surface);
      CloseEllipse(surface, close, &surface, &scratch);
      // Beyond the view's own edges the surface continues (replicated), as if the view went on.
      // (A crop's other edges are off the surface, and so is the ring inside them, or they are
      // farther than the margin from `exact`.)
      const bool crop_at_border =
          at_border &&
          (crop.x == 0 || crop.y == 0 || crop.br().x == whole.width || crop.br().y == whole.height);
      const int pad = crop_at_border ? r + 1 : 0;
      cv::copyMakeBorder(surface, padded, pad, pad, pad, pad, cv::BORDER_REPLICATE);
      // Seeds: pixels of the band with no pixel off the surface nearer than the radius.
      cv::compare(padded, 0, off, cv::CMP_EQ);
      NearerThan(off, radius, &near_off, &scratch);
      cv::compare(band_of(crop), k, in_band, cv::CMP_EQ);
      cv::bitwise_not(near_off(cv::Rect(pad, pad, crop.width, crop.height)), seeds);
      seeds &= in_band;
      if (cv::countNonZero(seeds) == 0) continue;
      const cv::Rect inside = exact - crop.tl();
      cv::Mat target = body(exact);
      if (seeds_only) {
        target |= seeds(inside);
        continue;
      }
      DilateEllipse(seeds, 2 * r + 1, &grown, &scratch);
      target |= grown(inside) & surface(inside);
    }
  }
  return body(cv::Rect(region.x - outer.x, region.y - outer.y, region.width, region.height))
      .clone();
}

}  // namespace linesight
