#include "linesight/stereo/superpixels.h"

#include <algorithm>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "linesight/core/error.h"
#include "linesight/stereo/run_forest.h"

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
  // The nearest centres of a pixel sit in its own cell and the three cells of the quadrant it lies
  // in, so each quarter of a cell is one block with four fixed candidates.
  for (int vertical = 0; vertical < 2; ++vertical) {
    const int ya = vertical == 0 ? y0 : y_mid, yb = vertical == 0 ? y_mid : y1;
    const int gy_other = vertical == 0 ? gy - 1 : gy + 1;
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
        float cx[4], cy[4], cf[4][kChannels];
        for (int i = 0; i < 4; ++i) {
          const float* c = &centres[static_cast<size_t>(cells[i]) * kStride];
          cx[i] = c[0];
          cy[i] = c[1];
          for (int ch = 0; ch < kChannels; ++ch) cf[i][ch] = c[2 + ch];
        }
        if constexpr (kChannels == 1) {
          AssignGreyBlock(features.ptr<uint8_t>(), features.step1(), width, ya, yb, xa, xb, cells,
                          cx, cy, cf[0], spatial_weight, labels->ptr<int32_t>(), labels->step1());
          continue;
        }
        for (int y = ya; y < yb; ++y) {
          const uint8_t* f = features.ptr<uint8_t>(y);
          int32_t* out = labels->ptr<int32_t>(y);
          float row_term[4];
          for (int i = 0; i < 4; ++i) {
            const float dy = static_cast<float>(y) - cy[i];
            row_term[i] = spatial_weight * dy * dy;
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
  int32_t* label = labels->ptr<int32_t>();
  // Pieces: horizontal runs of equal labels, united with the touching runs of the same label in
  // the row above. Each piece's root is its first run, whose first pixel is the piece's first
  // pixel in raster order.
  RunForest forest = BuildRunForest(
      height, 4 * cv::getNumThreads(),
      [&](int y, std::vector<Run>* out) {
        const int32_t* l = label + static_cast<ptrdiff_t>(y) * width;
        for (int x = 0; x < width;) {
          int end = x + 1;
          while (end < width && l[end] == l[x]) ++end;
          out->push_back({x, end, l[x], 0});
          x = end;
        }
      },
      [](int, const Run& above, const Run& below) { return above.label == below.label; },
      [](int n, const auto& fn) {
        cv::parallel_for_(cv::Range(0, n), [&](const cv::Range& r) { fn(r.start, r.end); });
      });
  const std::vector<Run>& runs = forest.runs;
  const std::vector<int32_t>& row_begin = forest.row_begin;
  const int count = static_cast<int>(runs.size());
  // Piece sizes at the roots, then (at the roots) their new labels.
  std::vector<int32_t> root_info = std::move(forest.size);
  // New labels in raster order of the pieces' first pixels (serial: a small piece takes the new
  // label of the pixel before its first pixel, left or else above, which an earlier run already
  // decided), then the pixels in parallel.
  int next = 0;
  std::vector<int32_t> value(count);
  for (int y = 0; y < height; ++y) {
    for (int r = row_begin[y]; r < row_begin[y + 1]; ++r) {
      if (runs[r].parent != r) {
        value[r] = root_info[runs[r].parent];
        continue;
      }
      // The pixel before: its run is an earlier one, already relabelled.
      int adjacent = -1;
      if (runs[r].x0 > 0) {
        adjacent = value[r - 1];
      } else if (y > 0) {
        adjacent = value[row_begin[y - 1]];  // the first run of the row above
      }
      value[r] = root_info[r] < min_size && adjacent >= 0 ? adjacent : next++;
      root_info[r] = value[r];
    }
  }
  cv::parallel_for_(cv::Range(0, height), [&](const cv::Range& range) {
    for (int y = range.start; y < range.end; ++y) {
      int32_t* row = label + static_cast<ptrdiff_t>(y) * width;
      for (int r = row_begin[y]; r < row_begin[y + 1]; ++r) {
        std::fill(row + runs[r].x0, row + runs[r].x1, value[r]);
      }
    }
  });
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
  std::vector<int32_t> cell_of_column(width);
  for (int x = 0; x < width; ++x) {
    cell_of_column[x] = static_cast<int32_t>(static_cast<int64_t>(x) * grid_x / width);
  }
  for (int y = 0; y < height; ++y) {
    int32_t* l = labels.ptr<int32_t>(y);
    const int row_offset = static_cast<int>(static_cast<int64_t>(y) * grid_y / height) * grid_x;
    for (int x = 0; x < width; ++x) l[x] = row_offset + cell_of_column[x];
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
          if (channels == 1) {
            for (int x = 0; x < width; ++x) {
              int64_t* sum = &stripe_sum[static_cast<size_t>(l[x]) * 4];
              sum[0] += x;
              sum[1] += y;
              sum[2] += f[x];
              sum[3] += 1;
            }
            continue;
          }
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
