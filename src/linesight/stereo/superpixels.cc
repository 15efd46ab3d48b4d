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
        // Increasing index order, so that ties go to the smaller index (insertion sort of <= 4);
        // missing neighbours (image border) repeat the last candidate, which never wins a tie.
        for (int i = 1; i < n; ++i) {
          for (int j = i; j > 0 && cells[j - 1] > cells[j]; --j) std::swap(cells[j - 1], cells[j]);
        }
        for (int i = n; i < 4; ++i) cells[i] = cells[n - 1];
        float row_term[4], cx[4], cf[4][kChannels];
        for (int i = 0; i < 4; ++i) {
          const float* c = &centres[static_cast<size_t>(cells[i]) * kStride];
          const float dy = static_cast<float>(y) - c[1];
          cx[i] = c[0];
          row_term[i] = spatial_weight * dy * dy;
          for (int ch = 0; ch < kChannels; ++ch) cf[i][ch] = c[2 + ch];
        }
        // Branch-free selection over exactly four candidates.
        for (int x = xa; x < xb; ++x) {
          const uint8_t* px = f + static_cast<ptrdiff_t>(x) * kChannels;
          float value[kChannels];
          for (int ch = 0; ch < kChannels; ++ch) value[ch] = px[ch];
          float dist[4];
          for (int i = 0; i < 4; ++i) {
            const float dx = static_cast<float>(x) - cx[i];
            dist[i] = row_term[i] + spatial_weight * dx * dx;
            for (int ch = 0; ch < kChannels; ++ch) {
              const float dc = value[ch] - cf[i][ch];
              dist[i] += dc * dc;
            }
          }
          const bool first_pair = dist[0] <= dist[1];
          const float best01 = first_pair ? dist[0] : dist[1];
          const int id01 = first_pair ? cells[0] : cells[1];
          const bool second_pair = dist[2] <= dist[3];
          const float best23 = second_pair ? dist[2] : dist[3];
          const int id23 = second_pair ? cells[2] : cells[3];
          out[x] = best01 <= best23 ? id01 : id23;
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
  int32_t* label = labels->ptr<int32_t>();
  // Union-find over 4-neighbours with the same label; a root is the smallest pixel index of its
  // piece, i.e. the piece's first pixel in raster order.
  std::vector<int32_t> parent(total);
  auto find = [&](int32_t p) {
    while (parent[p] != p) {
      parent[p] = parent[parent[p]];
      p = parent[p];
    }
    return p;
  };
  auto unite = [&](int32_t a, int32_t b) {
    a = find(a), b = find(b);
    if (a < b) {
      parent[b] = a;
    } else if (b < a) {
      parent[a] = b;
    }
  };
  for (int y = 0, p = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x, ++p) {
      parent[p] = p;
      if (x > 0 && label[p - 1] == label[p]) unite(p - 1, p);
      if (y > 0 && label[p - width] == label[p]) unite(p - width, p);
    }
  }
  // Piece sizes, stored at the roots (then replaced there by the piece's new label).
  std::vector<int32_t> root_info(total, 0);
  for (int p = 0; p < total; ++p) {
    parent[p] = find(p);
    ++root_info[parent[p]];
  }
  // New labels in raster order of the pieces' first pixels. A small piece joins the piece of the
  // pixel that precedes its first pixel (left, else above), which is already labelled.
  int next = 0;
  for (int y = 0, p = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x, ++p) {
      if (parent[p] != p) {
        label[p] = root_info[parent[p]];
        continue;
      }
      int adjacent = -1;
      if (x > 0) {
        adjacent = label[p - 1];
      } else if (y > 0) {
        adjacent = label[p - width];
      }
      root_info[p] = root_info[p] < min_size && adjacent >= 0 ? adjacent : next++;
      label[p] = root_info[p];
    }
  }
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
  // Sums over a fixed number of row stripes in parallel, then added in order: integers, so exact.
  constexpr int kStripes = 4;
  const size_t sum_size = static_cast<size_t>(clusters) * (stride + 1);
  std::vector<int64_t> stripe_sums(sum_size * kStripes);
  std::vector<int64_t> sums(sum_size);
  for (int iteration = 0; iteration < options.iterations; ++iteration) {
    std::fill(stripe_sums.begin(), stripe_sums.end(), 0);
    cv::parallel_for_(cv::Range(0, kStripes), [&](const cv::Range& range) {
      for (int stripe = range.start; stripe < range.end; ++stripe) {
        int64_t* stripe_sum = &stripe_sums[sum_size * stripe];
        for (int y = height * stripe / kStripes; y < height * (stripe + 1) / kStripes; ++y) {
          const int32_t* l = labels.ptr<int32_t>(y);
          const uint8_t* f = features.ptr<uint8_t>(y);
          for (int x = 0; x < width; ++x) {
            int64_t* sum = &stripe_sum[static_cast<size_t>(l[x]) * (stride + 1)];
            sum[0] += x;
            sum[1] += y;
            for (int ch = 0; ch < channels; ++ch) sum[2 + ch] += f[x * channels + ch];
            sum[stride] += 1;
          }
        }
      }
    });
    for (size_t i = 0; i < sum_size; ++i) {
      int64_t total = 0;
      for (int stripe = 0; stripe < kStripes; ++stripe) total += stripe_sums[sum_size * stripe + i];
      sums[i] = total;
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
