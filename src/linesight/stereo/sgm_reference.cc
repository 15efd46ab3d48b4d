#include "linesight/stereo/sgm_reference.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdlib>
#include <utility>

namespace linesight::reference {

using detail::kSgmInvalidFixed;

std::vector<uint64_t> Census(const cv::Mat& gray, int window_width, int window_height) {
  const int ww = window_width, wh = window_height;
  const int w = gray.cols, h = gray.rows;
  std::vector<uint64_t> codes(static_cast<size_t>(w) * h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const int centre = gray.at<uint8_t>(y, x);
      uint64_t code = 0;
      int bit = 0;
      for (int dy = -wh / 2; dy <= wh / 2; ++dy) {
        for (int dx = -ww / 2; dx <= ww / 2; ++dx) {
          if (dx == 0 && dy == 0) continue;
          const int v =
              gray.at<uint8_t>(std::clamp(y + dy, 0, h - 1), std::clamp(x + dx, 0, w - 1));
          if (v < centre) code |= uint64_t{1} << bit;
          ++bit;
        }
      }
      codes[static_cast<size_t>(y) * w + x] = code;
    }
  }
  return codes;
}

int BirchfieldTomasi2(const uint8_t* left, const uint8_t* right, int width, int x, int xr) {
  const int w = width;
  auto range = [w](const uint8_t* row, int i, int* lo, int* hi) {
    const int c = 2 * row[i];
    const int minus = row[i] + row[std::max(i - 1, 0)];
    const int plus = row[i] + row[std::min(i + 1, w - 1)];
    *lo = std::min({c, minus, plus});
    *hi = std::max({c, minus, plus});
  };
  int lmin, lmax, rmin, rmax;
  range(left, x, &lmin, &lmax);
  range(right, xr, &rmin, &rmax);
  const int il = 2 * left[x], ir = 2 * right[xr];
  const int d_lr = std::max({0, il - rmax, rmin - il});
  const int d_rl = std::max({0, ir - lmax, lmin - ir});
  return std::min(d_lr, d_rl);
}

std::vector<uint16_t> MatchingCost(const detail::CostInput& in) {
  const int w = in.width, h = in.height, num = in.num_disparities, dmin = in.min_disparity;
  const int max_cost = in.census_bits + (in.bt_weight * 2 * in.bt_truncation) / 16;
  auto at = [&](int y, int x, int k) { return (static_cast<size_t>(y) * w + x) * num + k; };
  std::vector<uint16_t> costs(static_cast<size_t>(w) * h * num, 0);
  for (int y = 0; y < h; ++y) {
    const uint8_t* left_row = in.gray_left + static_cast<size_t>(y) * w;
    const uint8_t* right_row = in.gray_right + static_cast<size_t>(y) * w;
    for (int x = 0; x < w; ++x) {
      for (int k = 0; k < num; ++k) {
        const int xr = x - dmin - k;
        int cost = max_cost;
        if (xr >= 0 && xr < w) {
          cost = std::popcount(in.census_left[static_cast<size_t>(y) * w + x] ^
                               in.census_right[static_cast<size_t>(y) * w + xr]);
          if (in.bt_weight > 0) {
            const int bt2 = BirchfieldTomasi2(left_row, right_row, w, x, xr);
            cost += (in.bt_weight * std::min(bt2, 2 * in.bt_truncation)) / 16;
          }
        }
        costs[at(y, x, k)] = static_cast<uint16_t>(cost);
      }
    }
  }
  return costs;
}

std::vector<uint32_t> AggregatePaths(const detail::AggregationInput& in,
                                     const std::vector<uint16_t>& cost) {
  const int w = in.cost.width, h = in.cost.height, num = in.cost.num_disparities;
  const uint8_t* gray = in.cost.gray_left;
  auto at = [&](int y, int x, int k) { return (static_cast<size_t>(y) * w + x) * num + k; };
  // One direction at a time, straight from the recurrence.
  std::vector<std::pair<int, int>> directions = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
  if (in.num_paths == 8) directions.insert(directions.end(), {{1, 1}, {-1, 1}, {1, -1}, {-1, -1}});
  std::vector<uint32_t> sum(cost.size(), 0);
  std::vector<int> path(cost.size());
  for (const auto& [dx, dy] : directions) {
    for (int yi = 0; yi < h; ++yi) {
      const int y = dy >= 0 ? yi : h - 1 - yi;
      for (int xi = 0; xi < w; ++xi) {
        const int x = dx >= 0 ? xi : w - 1 - xi;
        const int px = x - dx, py = y - dy;
        const bool start = px < 0 || px >= w || py < 0 || py >= h;
        int prev_min = 0, p2 = in.p2;
        if (!start) {
          prev_min = *std::min_element(&path[at(py, px, 0)], &path[at(py, px, 0)] + num);
          const int step = std::abs(gray[static_cast<size_t>(y) * w + x] -
                                    gray[static_cast<size_t>(py) * w + px]);
          if (in.p2_gradient_alpha > 0) {
            p2 = std::max(in.p1 + 1, in.p2 * in.p2_gradient_alpha / (in.p2_gradient_alpha + step));
          }
        }
        for (int k = 0; k < num; ++k) {
          int value = cost[at(y, x, k)];
          if (!start) {
            int best = path[at(py, px, k)];
            if (k > 0) best = std::min(best, path[at(py, px, k - 1)] + in.p1);
            if (k + 1 < num) best = std::min(best, path[at(py, px, k + 1)] + in.p1);
            best = std::min(best, prev_min + p2);
            value += best - prev_min;
          }
          path[at(y, x, k)] = value;
          sum[at(y, x, k)] += value;
        }
      }
    }
  }
  return sum;
}

WinnerTakesAllResult WinnerTakesAll(const std::vector<uint32_t>& sum, int width, int height,
                                    int num_disparities, int min_disparity) {
  const int w = width, h = height, num = num_disparities, dmin = min_disparity;
  auto at = [&](int y, int x, int k) { return (static_cast<size_t>(y) * w + x) * num + k; };
  WinnerTakesAllResult r;
  r.best.assign(static_cast<size_t>(w) * h, 0);
  r.best_cost = r.second = r.right_best = r.best;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const uint32_t* s = &sum[at(y, x, 0)];
      const int best = static_cast<int>(std::min_element(s, s + num) - s);
      int second = 0xFFFF;
      for (int k = 0; k < num; ++k) {
        if (std::abs(k - best) > 1) second = std::min(second, static_cast<int>(s[k]));
      }
      const size_t i = static_cast<size_t>(y) * w + x;
      r.best[i] = best;
      r.best_cost[i] = static_cast<int>(s[best]);
      r.second[i] = second;
    }
    for (int xr = 0; xr < w; ++xr) {
      int best = -1;
      uint32_t best_cost = 0;
      for (int k = 0; k < num; ++k) {
        const int x = xr + dmin + k;
        if (x < 0 || x >= w) continue;
        if (best < 0 || sum[at(y, x, k)] < best_cost) {
          best = k;
          best_cost = sum[at(y, x, k)];
        }
      }
      r.right_best[static_cast<size_t>(y) * w + xr] = best;
    }
  }
  return r;
}

cv::Mat SelectDisparities(const std::vector<uint32_t>& sum, const WinnerTakesAllResult& winners,
                          int width, int height, const SgmOptions& o) {
  const int w = width, h = height, num = o.num_disparities, dmin = o.min_disparity;
  auto at = [&](int y, int x, int k) { return (static_cast<size_t>(y) * w + x) * num + k; };
  const WinnerTakesAllResult& r = winners;
  cv::Mat fixed(h, w, CV_16SC1);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      const int best = r.best[i];
      int16_t& out = fixed.at<int16_t>(y, x);
      out = kSgmInvalidFixed;
      if (x - dmin < 0 || x - dmin - (num - 1) >= w) continue;
      if (static_cast<int64_t>(r.second[i]) * (100 - o.uniqueness_ratio) <
          int64_t{r.best_cost[i]} * 100)
        continue;
      const int xr = x - dmin - best;
      if (xr < 0 || xr >= w) continue;
      const int right = r.right_best[static_cast<size_t>(y) * w + xr];
      if (right < 0 || std::abs(right - best) > o.lr_max_diff) continue;
      double offset = 0;
      if (best > 0 && best < num - 1 && o.subpixel != SgmSubpixel::kNone) {
        const double c0 = sum[at(y, x, best - 1)], c1 = sum[at(y, x, best)],
                     c2 = sum[at(y, x, best + 1)];
        const double den = o.subpixel == SgmSubpixel::kEquiangular ? 2 * (std::max(c0, c2) - c1)
                                                                   : 2 * (c0 + c2 - 2 * c1);
        if (den > 0) offset = std::round((c0 - c2) * kSgmSubpixelScale / den);
      }
      out = static_cast<int16_t>((dmin + best) * kSgmSubpixelScale + static_cast<int>(offset));
    }
  }
  return fixed;
}

cv::Mat MedianValid3x3(const cv::Mat& src) {
  cv::Mat dst(src.size(), CV_16SC1, cv::Scalar(kSgmInvalidFixed));
  for (int y = 0; y < src.rows; ++y) {
    for (int x = 0; x < src.cols; ++x) {
      if (src.at<int16_t>(y, x) == kSgmInvalidFixed) continue;
      std::vector<int16_t> values;
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          const int yy = y + dy, xx = x + dx;
          if (yy < 0 || yy >= src.rows || xx < 0 || xx >= src.cols) continue;
          if (src.at<int16_t>(yy, xx) != kSgmInvalidFixed)
            values.push_back(src.at<int16_t>(yy, xx));
        }
      }
      std::sort(values.begin(), values.end());
      dst.at<int16_t>(y, x) = values[(values.size() - 1) / 2];
    }
  }
  return dst;
}

}  // namespace linesight::reference
