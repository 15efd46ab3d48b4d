#include "linesight/stereo/superpixels.h"

#include <algorithm>
#include <cstdint>
#include <limits>
#include <vector>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "linesight/core/error.h"

namespace linesight {

void SuperpixelOptions::Check() const {
  CheckOption(region_size >= 4, "SuperpixelOptions.region_size", region_size, "must be >= 4");
  CheckOption(compactness > 0, "SuperpixelOptions.compactness", compactness, "must be > 0");
  CheckOption(iterations >= 1, "SuperpixelOptions.iterations", iterations, "must be >= 1");
  CheckOption(min_size_ratio >= 0 && min_size_ratio <= 1, "SuperpixelOptions.min_size_ratio",
              min_size_ratio, "must be in [0, 1]");
}

namespace detail {
namespace {

// First pixel column of grid cell `cell` when `size` pixels are split into `cells` cells.
int CellStart(int cell, int size, int cells) {
  return static_cast<int>((static_cast<int64_t>(cell) * size + cells - 1) / cells);
}

template <int kChannels>
void AssignBand(const cv::Mat& features, const std::vector<float>& centres, int grid_x, int grid_y,
                float spatial_weight, int gy, cv::Mat* labels) {
  constexpr int kStride = 2 + kChannels;
  const int width = features.cols, height = features.rows;
  const int y0 = CellStart(gy, height, grid_y), y1 = CellStart(gy + 1, height, grid_y);
  const int y_mid = (y0 + y1) / 2;
  for (int y = y0; y < y1; ++y) {
    const uint8_t* f = features.ptr<uint8_t>(y);
    int32_t* out = labels->ptr<int32_t>(y);
    // The nearest centres of a pixel sit in its own cell and the three cells of the quadrant it
    // lies in.
    const int gy_other = y < y_mid ? gy - 1 : gy + 1;
    const bool has_other_row = gy_other >= 0 && gy_other < grid_y;
    for (int gx = 0; gx < grid_x; ++gx) {
      const int x0 = CellStart(gx, width, grid_x), x1 = CellStart(gx + 1, width, grid_x);
      const int x_mid = (x0 + x1) / 2;
      for (int half = 0; half < 2; ++half) {
        const int xa = half == 0 ? x0 : x_mid, xb = half == 0 ? x_mid : x1;
        const int gx_other = half == 0 ? gx - 1 : gx + 1;
        const bool has_other_col = gx_other >= 0 && gx_other < grid_x;
        int cells[4];
        int n = 0;
        cells[n++] = gy * grid_x + gx;
        if (has_other_col) cells[n++] = gy * grid_x + gx_other;
        if (has_other_row) cells[n++] = gy_other * grid_x + gx;
        if (has_other_row && has_other_col) cells[n++] = gy_other * grid_x + gx_other;
        // Increasing index order, so that ties go to the smaller index (insertion sort of <= 4).
        for (int i = 1; i < n; ++i) {
          for (int j = i; j > 0 && cells[j - 1] > cells[j]; --j) std::swap(cells[j - 1], cells[j]);
        }
        float row_term[4], cx[4], cf[4][kChannels];
        for (int i = 0; i < n; ++i) {
          const float* c = &centres[static_cast<size_t>(cells[i]) * kStride];
          const float dy = static_cast<float>(y) - c[1];
          cx[i] = c[0];
          row_term[i] = spatial_weight * dy * dy;
          for (int ch = 0; ch < kChannels; ++ch) cf[i][ch] = c[2 + ch];
        }
        for (int x = xa; x < xb; ++x) {
          const uint8_t* px = f + static_cast<ptrdiff_t>(x) * kChannels;
          float best = std::numeric_limits<float>::max();
          int best_i = 0;
          for (int i = 0; i < n; ++i) {
            const float dx = static_cast<float>(x) - cx[i];
            float dist = row_term[i] + spatial_weight * dx * dx;
            for (int ch = 0; ch < kChannels; ++ch) {
              const float dc = static_cast<float>(px[ch]) - cf[i][ch];
              dist += dc * dc;
            }
            if (dist < best) {
              best = dist;
              best_i = i;
            }
          }
          out[x] = cells[best_i];
        }
      }
    }
  }
}

}  // namespace

void AssignPixelsToCentres(const cv::Mat& features, const std::vector<float>& centres, int grid_x,
                           int grid_y, double spatial_weight, cv::Mat* labels) {
  LS_CHECK(features.type() == CV_8UC1 || features.type() == CV_8UC3);
  const int channels = features.channels();
  LS_CHECK(centres.size() == static_cast<size_t>(grid_x) * grid_y * (2 + channels));
  labels->create(features.size(), CV_32SC1);
  const float weight = static_cast<float>(spatial_weight);
  cv::parallel_for_(cv::Range(0, grid_y), [&](const cv::Range& range) {
    for (int gy = range.start; gy < range.end; ++gy) {
      if (channels == 3) {
        AssignBand<3>(features, centres, grid_x, grid_y, weight, gy, labels);
      } else {
        AssignBand<1>(features, centres, grid_x, grid_y, weight, gy, labels);
      }
    }
  });
}

int EnforceConnectivity(cv::Mat* labels, int min_size) {
  LS_CHECK(labels->type() == CV_32SC1 && labels->isContinuous());
  const int width = labels->cols, height = labels->rows;
  const int total = width * height;
  int32_t* old_labels = labels->ptr<int32_t>();
  std::vector<int32_t> new_labels(total, -1);
  std::vector<int32_t> piece;
  piece.reserve(1024);
  int next = 0;
  for (int start = 0; start < total; ++start) {
    if (new_labels[start] >= 0) continue;
    const int32_t old = old_labels[start];
    // The neighbour that precedes the piece in raster order (left, else above) is already labelled.
    const int sx = start % width;
    int adjacent = -1;
    if (sx > 0) adjacent = new_labels[start - 1];
    if (adjacent < 0 && start >= width) adjacent = new_labels[start - width];
    piece.clear();
    piece.push_back(start);
    new_labels[start] = next;
    for (size_t i = 0; i < piece.size(); ++i) {
      const int p = piece[i];
      const int px = p % width;
      const int neighbours[4] = {px > 0 ? p - 1 : -1, px + 1 < width ? p + 1 : -1,
                                 p >= width ? p - width : -1, p + width < total ? p + width : -1};
      for (int q : neighbours) {
        if (q >= 0 && new_labels[q] < 0 && old_labels[q] == old) {
          new_labels[q] = next;
          piece.push_back(q);
        }
      }
    }
    if (static_cast<int>(piece.size()) < min_size && adjacent >= 0) {
      for (int p : piece) new_labels[p] = adjacent;
    } else {
      ++next;
    }
  }
  std::copy(new_labels.begin(), new_labels.end(), old_labels);
  return next;
}

}  // namespace detail

cv::Mat SegmentSuperpixels(const cv::Mat& image, const SuperpixelOptions& options,
                           int* num_segments) {
  options.Check();
  if (image.empty()) throw InputError("superpixel input image is empty");
  if (image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3)) {
    throw InputError(
        fmt::format("superpixel input must be 8-bit grey or BGR, got type {}", image.type()));
  }
  cv::Mat features;
  if (image.channels() == 3) {
    cv::cvtColor(image, features, cv::COLOR_BGR2Lab);
  } else {
    features = image.isContinuous() ? image : image.clone();
  }
  const int channels = features.channels();
  const int stride = 2 + channels;
  const int width = image.cols, height = image.rows;
  const int size = options.region_size;
  const int grid_x = std::max(1, (width + size / 2) / size);
  const int grid_y = std::max(1, (height + size / 2) / size);
  const int clusters = grid_x * grid_y;

  // The grid cells are the initial partition: every round first moves each centre to the mean
  // position and colour of its pixels (exact integer sums, so the order of summation does not
  // matter), then reassigns.
  cv::Mat labels(height, width, CV_32SC1);
  for (int y = 0; y < height; ++y) {
    int32_t* l = labels.ptr<int32_t>(y);
    const int gy = static_cast<int>(static_cast<int64_t>(y) * grid_y / height);
    for (int x = 0; x < width; ++x) {
      l[x] = gy * grid_x + static_cast<int>(static_cast<int64_t>(x) * grid_x / width);
    }
  }
  std::vector<float> centres(static_cast<size_t>(clusters) * stride);
  const double spatial_weight = (options.compactness / size) * (options.compactness / size);
  std::vector<int64_t> sums(static_cast<size_t>(clusters) * (stride + 1));
  for (int iteration = 0; iteration < options.iterations; ++iteration) {
    std::fill(sums.begin(), sums.end(), 0);
    for (int y = 0; y < height; ++y) {
      const int32_t* l = labels.ptr<int32_t>(y);
      const uint8_t* f = features.ptr<uint8_t>(y);
      for (int x = 0; x < width; ++x) {
        int64_t* sum = &sums[static_cast<size_t>(l[x]) * (stride + 1)];
        sum[0] += x;
        sum[1] += y;
        for (int ch = 0; ch < channels; ++ch) sum[2 + ch] += f[x * channels + ch];
        sum[stride] += 1;
      }
    }
    for (int k = 0; k < clusters; ++k) {
      const int64_t* sum = &sums[static_cast<size_t>(k) * (stride + 1)];
      float* centre = &centres[static_cast<size_t>(k) * stride];
      if (sum[stride] == 0) {  // an emptied cluster stays where it was, out of reach of any pixel
        if (iteration == 0) std::fill(centre, centre + stride, 0.0f);
        continue;
      }
      const double inv = 1.0 / static_cast<double>(sum[stride]);
      for (int i = 0; i < stride; ++i) centre[i] = static_cast<float>(sum[i] * inv);
    }
    detail::AssignPixelsToCentres(features, centres, grid_x, grid_y, spatial_weight, &labels);
  }
  const int min_size = static_cast<int>(options.min_size_ratio * size * size);
  const int n = detail::EnforceConnectivity(&labels, min_size);
  if (num_segments) *num_segments = n;
  return labels;
}

}  // namespace linesight
