// Exact comparisons of every optimised SGM stage with its naive scalar reference (sgm_reference.h,
// CONVENTIONS.md §7) for every Highway target this CPU supports, on awkward sizes, disparity
// ranges, path counts and thread counts.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <tuple>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <hwy/tests/hwy_gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "linesight/core/disparity.h"
#include "linesight/stereo/sgm.h"
#include "linesight/stereo/sgm_reference.h"
#include "linesight/stereo/sgm_stages.h"

namespace linesight {
namespace {

using detail::kSgmInvalidFixed;

// ------------------------------------------------------------------------------------------ test
// images A textured pair with a slanted disparity plane plus a nearer box, seeded; `width` x
// `height`.
void MakePair(int width, int height, double d0, uint64_t seed, cv::Mat* left, cv::Mat* right) {
  cv::RNG rng(seed);
  cv::Mat noise(height / 2 + 2, width / 2 + 40, CV_8UC1);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 256);
  cv::Mat texture;
  cv::resize(noise, texture, cv::Size(noise.cols * 2, noise.rows * 2), 0, 0, cv::INTER_CUBIC);
  *left = texture(cv::Rect(40, 0, width, height)).clone();
  right->create(height, width, CV_8UC1);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const bool box = x > width / 3 && x < width / 2 && y > height / 3 && y < height * 2 / 3;
      const double d = d0 + 0.02 * x + 0.01 * y + (box ? 6 : 0);
      const int src = static_cast<int>(std::lround(x + d)) + 40;
      right->at<uint8_t>(y, x) = texture.at<uint8_t>(y, std::min(src, texture.cols - 1));
    }
  }
}

struct Config {
  int width = 311, height = 239;
  int min_disparity = 0, num_disparities = 37;
  int paths = 8;
  int threads = 1;
  int bt_weight = 0;
  int alpha = 0;
  int p2 = SgmOptions().p2;
  int uniqueness = 0;
  int lr_max_diff = 2;
  SgmSubpixel subpixel = SgmSubpixel::kEquiangular;
  int census_width = 9, census_height = 7;
};

std::string Describe(const Config& c) {
  return fmt::format(
      "{}x{} dmin={} num={} paths={} threads={} bt={} alpha={} p2={} u={} lr={} subpixel={} "
      "census={}x{}",
      c.width, c.height, c.min_disparity, c.num_disparities, c.paths, c.threads, c.bt_weight,
      c.alpha, c.p2, c.uniqueness, c.lr_max_diff, static_cast<int>(c.subpixel), c.census_width,
      c.census_height);
}

SgmOptions OptionsFor(const Config& c) {
  SgmOptions o;
  o.min_disparity = c.min_disparity;
  o.num_disparities = c.num_disparities;
  o.num_paths = c.paths;
  o.threads = c.threads;
  o.bt_weight = c.bt_weight;
  o.p2_gradient_alpha = c.alpha;
  o.p2 = c.p2;
  o.uniqueness_ratio = c.uniqueness;
  o.lr_max_diff = c.lr_max_diff;
  o.subpixel = c.subpixel;
  o.census_width = c.census_width;
  o.census_height = c.census_height;
  return o;
}

struct Reference {
  cv::Mat left, right;
  std::vector<uint64_t> census_left, census_right;
  std::vector<uint16_t> cost;  // [y][x][k], num_disparities lanes
  std::vector<uint32_t> sum;   // [y][x][k]
  reference::WinnerTakesAllResult winners;
  cv::Mat disparity;  // final float output
};

detail::CostInput CostInputFor(const Config& c, const Reference& r) {
  detail::CostInput in;
  in.width = c.width;
  in.height = c.height;
  in.min_disparity = c.min_disparity;
  in.num_disparities = c.num_disparities;
  in.census_bits = c.census_width * c.census_height - 1;
  in.bt_weight = c.bt_weight;
  in.bt_truncation = SgmOptions().bt_truncation;
  in.census_left = r.census_left.data();
  in.census_right = r.census_right.data();
  in.gray_left = r.left.ptr<uint8_t>();
  in.gray_right = r.right.ptr<uint8_t>();
  return in;
}

detail::AggregationInput AggregationInputFor(const Config& c, const Reference& r) {
  const SgmOptions o = OptionsFor(c);
  detail::AggregationInput in;
  in.cost = CostInputFor(c, r);
  in.num_paths = o.num_paths;
  in.p1 = o.p1;
  in.p2 = o.p2;
  in.p2_gradient_alpha = o.p2_gradient_alpha;
  return in;
}

// Every stage of the pipeline from its reference; the speckle filter is OpenCV's, used as is.
Reference ComputeReference(const Config& c) {
  Reference r;
  MakePair(c.width, c.height, std::max(0, c.min_disparity) + 4, 11, &r.left, &r.right);
  const SgmOptions o = OptionsFor(c);
  r.census_left = reference::Census(r.left, c.census_width, c.census_height);
  r.census_right = reference::Census(r.right, c.census_width, c.census_height);
  const detail::AggregationInput in = AggregationInputFor(c, r);
  r.cost = reference::MatchingCost(in.cost);
  r.sum = reference::AggregatePaths(in, r.cost);
  r.winners =
      reference::WinnerTakesAll(r.sum, c.width, c.height, c.num_disparities, c.min_disparity);
  cv::Mat fixed = reference::SelectDisparities(r.sum, r.winners, c.width, c.height, o);
  cv::filterSpeckles(fixed, kSgmInvalidFixed, o.speckle_window,
                     static_cast<int>(std::lround(o.speckle_range * kSgmSubpixelScale)));
  const cv::Mat median = reference::MedianValid3x3(fixed);
  r.disparity.create(c.height, c.width, CV_32FC1);
  for (int y = 0; y < c.height; ++y) {
    for (int x = 0; x < c.width; ++x) {
      const int v = median.at<int16_t>(y, x);
      r.disparity.at<float>(y, x) = v == kSgmInvalidFixed ? kInvalidDisparity : v / 16.0f;
    }
  }
  return r;
}

// References are expensive; compute each configuration once for all targets.
const Reference& CachedReference(const Config& c) {
  static std::map<std::string, Reference> cache;
  const std::string key = Describe(c);
  auto it = cache.find(key);
  if (it == cache.end()) it = cache.emplace(key, ComputeReference(c)).first;
  return it->second;
}

// Configurations: odd sizes, num-disp 37 and 64, min-disp 0 / positive / negative, 4 and 8 paths, 1
// and 2 threads, uint8 and uint16 path costs, BT on/off, gradient-adapted P2 on/off, both subpixel
// modes, a non-default census window.
std::vector<Config> Configs() {
  std::vector<Config> configs;
  Config c;
  configs.push_back(c);  // 311x239, 0..36, 8 paths, 1 thread
  c.num_disparities = 64;
  c.min_disparity = 5;
  c.paths = 4;
  c.threads = 2;
  c.uniqueness = 10;
  c.lr_max_diff = 1;
  configs.push_back(c);
  c.uniqueness = 0;
  c.lr_max_diff = 0;
  c.p2 = 300;  // census only, but too large a P2 for uint8 path costs
  c.paths = 8;
  configs.push_back(c);
  c.p2 = SgmOptions().p2;
  c.num_disparities = 37;
  c.min_disparity = -3;
  c.paths = 8;
  c.threads = 2;
  c.bt_weight = 12;
  c.alpha = 40;
  c.subpixel = SgmSubpixel::kParabola;
  configs.push_back(c);
  Config small;
  small.width = 67;
  small.height = 13;
  small.num_disparities = 64;
  small.min_disparity = 9;
  small.threads = 3;
  small.census_width = 5;
  small.census_height = 5;
  configs.push_back(small);
  // Wide disparity ranges: 6 and 10 vectors of 32 lanes per pixel (the register and the generic
  // winner-takes-all of AVX-512), a negative range start.
  Config wide = small;
  wide.width = 97;
  wide.height = 15;
  wide.min_disparity = -60;
  wide.num_disparities = 170;
  wide.threads = 2;
  configs.push_back(wide);
  wide.min_disparity = -150;
  wide.num_disparities = 300;
  wide.paths = 4;
  configs.push_back(wide);
  // Whole vectors per pixel with 8 paths and packed census costs: the unrolled sweeps of 2 and 4
  // vectors (128 disparities on AVX-512 and AVX2, 256 on AVX-512; 64 on AVX2 / SSE4 above).
  Config whole = small;
  whole.width = 83;
  whole.height = 11;
  whole.min_disparity = 3;
  whole.num_disparities = 128;
  whole.threads = 2;
  configs.push_back(whole);
  whole.width = 301;
  whole.min_disparity = -7;
  whole.num_disparities = 256;
  whole.census_width = 9;
  whole.census_height = 7;
  configs.push_back(whole);
  return configs;
}

class SgmKernelTest : public hwy::TestWithParamTarget {};
HWY_TARGET_INSTANTIATE_TEST_SUITE_P(SgmKernelTest);

TEST_P(SgmKernelTest, CensusEqualsReference) {
  for (const Config& c : Configs()) {
    const Reference& r = CachedReference(c);
    std::vector<uint64_t> codes(static_cast<size_t>(c.width) * c.height);
    // Two row ranges, as two threads would compute them.
    detail::CensusTransform(r.left, c.census_width, c.census_height, 0, c.height / 3, codes.data());
    detail::CensusTransform(r.left, c.census_width, c.census_height, c.height / 3, c.height,
                            codes.data());
    ASSERT_EQ(codes, r.census_left) << Describe(c);
  }
}

TEST_P(SgmKernelTest, MatchingCostEqualsReference) {
  for (const Config& c : Configs()) {
    const Reference& r = CachedReference(c);
    const detail::CostInput in = CostInputFor(c, r);
    const int padded = detail::PaddedDisparities(c.num_disparities);
    std::vector<uint16_t> row(static_cast<size_t>(c.width) * padded);
    for (int y = 0; y < c.height; y += 7) {
      detail::MatchingCostRow(in, y, row.data());
      for (int x = 0; x < c.width; ++x) {
        for (int k = 0; k < c.num_disparities; ++k) {
          ASSERT_EQ(row[static_cast<size_t>(x) * padded + k],
                    r.cost[(static_cast<size_t>(y) * c.width + x) * c.num_disparities + k])
              << Describe(c) << " at x=" << x << " y=" << y << " k=" << k;
        }
      }
    }
  }
}

TEST_P(SgmKernelTest, AggregationAndWinnerTakesAllEqualReference) {
  for (const Config& c : Configs()) {
    const Reference& r = CachedReference(c);
    const detail::AggregationInput in = AggregationInputFor(c, r);
    for (int threads : {1, 2}) {
      detail::SumVolume partial;
      detail::SweepScratch forward, backward;
      const int num = c.num_disparities;
      const int padded = detail::PaddedDisparities(num);
      std::vector<uint16_t> sum(static_cast<size_t>(c.width) * c.height * padded);
      std::vector<int> calls(c.height, 0);
      detail::AggregatePaths(in, threads, &partial, &forward, &backward,
                             [&](int y, const uint16_t* row) {
                               std::copy(row, row + static_cast<size_t>(c.width) * padded,
                                         sum.begin() + static_cast<size_t>(y) * c.width * padded);
                               ++calls[y];
                             });
      ASSERT_EQ(calls, std::vector<int>(c.height, 1));
      auto sum_row = [&](int y) { return sum.data() + static_cast<size_t>(y) * c.width * padded; };
      for (int y = 0; y < c.height; ++y) {
        for (int x = 0; x < c.width; ++x) {
          const uint16_t* s = sum_row(y) + static_cast<size_t>(x) * padded;
          for (int k = 0; k < num; ++k) {
            ASSERT_EQ(s[k], r.sum[(static_cast<size_t>(y) * c.width + x) * num + k])
                << Describe(c) << " threads=" << threads << " at x=" << x << " y=" << y
                << " k=" << k;
          }
          for (int k = num; k < padded; ++k) ASSERT_EQ(s[k], 0xFFFF);
        }
      }
      std::vector<int16_t> best(c.width), right_best(c.width);
      std::vector<uint16_t> best_cost(c.width), second(c.width);
      std::vector<uint16_t> scratch(detail::WtaScratchSize(c.width, num));
      for (int y = 0; y < c.height; ++y) {
        detail::WinnerTakesAllRow(sum_row(y), c.width, num, c.min_disparity,
                                  {best.data(), best_cost.data(), second.data(), right_best.data()},
                                  scratch.data());
        for (int x = 0; x < c.width; ++x) {
          const size_t i = static_cast<size_t>(y) * c.width + x;
          ASSERT_EQ(best[x], r.winners.best[i]) << Describe(c) << " x=" << x << " y=" << y;
          ASSERT_EQ(best_cost[x], r.winners.best_cost[i])
              << Describe(c) << " x=" << x << " y=" << y;
          ASSERT_EQ(second[x], r.winners.second[i]) << Describe(c) << " x=" << x << " y=" << y;
          ASSERT_EQ(right_best[x], r.winners.right_best[i])
              << Describe(c) << " xr=" << x << " y=" << y;
        }
        // Without the second best (what Compute asks for when the uniqueness ratio is 0) the other
        // outputs are the same.
        std::vector<int16_t> best_only(c.width, -7), right_only(c.width, -7);
        std::vector<uint16_t> cost_only(c.width, 7);
        detail::WinnerTakesAllRow(sum_row(y), c.width, num, c.min_disparity,
                                  {best_only.data(), cost_only.data(), nullptr, right_only.data()},
                                  scratch.data());
        ASSERT_EQ(best_only, best) << Describe(c) << " y=" << y;
        ASSERT_EQ(cost_only, best_cost) << Describe(c) << " y=" << y;
        ASSERT_EQ(right_only, right_best) << Describe(c) << " y=" << y;
      }
    }
  }
}

TEST_P(SgmKernelTest, WholePipelineEqualsReferenceForAnyThreadCount) {
  for (const Config& c : Configs()) {
    const Reference& r = CachedReference(c);
    SgmMatcher matcher(OptionsFor(c));
    const cv::Mat disparity = matcher.Compute(r.left, r.right).disparity;
    ASSERT_EQ(disparity.type(), CV_32FC1);
    int valid = 0;
    for (int y = 0; y < c.height; ++y) {
      for (int x = 0; x < c.width; ++x) {
        const float got = disparity.at<float>(y, x), want = r.disparity.at<float>(y, x);
        ASSERT_TRUE(got == want || (std::isinf(got) && std::isinf(want)))
            << Describe(c) << " x=" << x << " y=" << y << " got " << got << " want " << want;
        valid += IsValidDisparity(want);
      }
    }
    // The comparison must not be vacuous: most pixels carry an estimate.
    EXPECT_GT(valid, c.width * c.height / 2) << Describe(c);
    // Reusing the matcher (scratch buffers) gives the same result.
    const cv::Mat again = matcher.Compute(r.left, r.right).disparity;
    EXPECT_EQ(cv::norm(disparity != again, cv::NORM_L1), 0) << Describe(c);
  }
}

// ------------------------------------------------------------------------------------------ scalar
// stages
TEST(SgmScalarStages, SubpixelOffsetsByHand) {
  const int equiangular = static_cast<int>(SgmSubpixel::kEquiangular);
  const int parabola = static_cast<int>(SgmSubpixel::kParabola);
  EXPECT_EQ(detail::SubpixelOffset(equiangular, 10, 4, 10), 0);
  // Minimum halfway to the left: c0 == c1.
  EXPECT_EQ(detail::SubpixelOffset(equiangular, 4, 4, 10), -8);
  EXPECT_EQ(detail::SubpixelOffset(equiangular, 10, 4, 4), 8);
  // Lines of slope 6 through (0, 4) and (1, 10), mirrored through (-1, 7): vertex at -0.25 → -4/16.
  EXPECT_EQ(detail::SubpixelOffset(equiangular, 7, 4, 10), -4);
  // Parabola through (-1, 7), (0, 4), (1, 10): vertex at -(10 - 7) / (2 * 9) = -1/6 → -2.67/16 →
  // -3.
  EXPECT_EQ(detail::SubpixelOffset(parabola, 7, 4, 10), -3);
  EXPECT_EQ(detail::SubpixelOffset(parabola, 4, 4, 4), 0);
  EXPECT_EQ(detail::SubpixelOffset(static_cast<int>(SgmSubpixel::kNone), 7, 4, 10), 0);
}

TEST(SgmScalarStages, LeftRightCheckByHand) {
  const int16_t right_best[6] = {-1, 3, 3, 5, 0, 2};
  // x = 5, min_disparity 1, best 3 → xr = 1 whose right winner is 3.
  EXPECT_TRUE(detail::LeftRightConsistent(5, 3, right_best, 6, 1, 0));
  // best 2 → xr = 2 (right winner 3): consistent within 1 px, not within 0.
  EXPECT_TRUE(detail::LeftRightConsistent(5, 2, right_best, 6, 1, 1));
  EXPECT_FALSE(detail::LeftRightConsistent(5, 2, right_best, 6, 1, 0));
  // xr = 0 has no right winner; xr < 0 is outside.
  EXPECT_FALSE(detail::LeftRightConsistent(5, 4, right_best, 6, 1, 5));
  EXPECT_FALSE(detail::LeftRightConsistent(2, 4, right_best, 6, 1, 5));
}

TEST_P(SgmKernelTest, MedianOfValidNeighboursEqualsReference) {
  cv::RNG rng(17);
  // Odd widths, a width below one vector, single rows / columns, every invalid density.
  const std::vector<std::pair<int, int>> sizes = {{311, 239}, {33, 7}, {1, 1},  {1, 9},
                                                  {70, 1},    {2, 2},  {65, 3}, {31, 4}};
  for (const auto& [w, h] : sizes) {
    for (const double invalid_fraction : {0.0, 0.3, 0.8, 1.0}) {
      cv::Mat src(h, w, CV_16SC1);
      for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
          // Extreme values too: INT16_MAX and INT16_MIN + 1 are valid disparities.
          const int kind = rng.uniform(0, 20);
          int16_t v = static_cast<int16_t>(rng.uniform(-2000, 2000));
          if (kind == 0) v = INT16_MAX;
          if (kind == 1) v = INT16_MIN + 1;
          if (rng.uniform(0.0, 1.0) < invalid_fraction) v = kSgmInvalidFixed;
          src.at<int16_t>(y, x) = v;
        }
      }
      const cv::Mat want = reference::MedianValid3x3(src);
      cv::Mat got(h, w, CV_16SC1, cv::Scalar(0));
      // Row ranges as threads would split them.
      detail::MedianValid3x3(src, got, 0, h / 3);
      detail::MedianValid3x3(src, got, h / 3, h);
      ASSERT_EQ(cv::norm(got != want, cv::NORM_L1), 0)
          << w << "x" << h << " invalid " << invalid_fraction;
    }
  }
}

TEST(SgmScalarStages, SpeckleFilterEqualsOpenCvForAnyThreadCount) {
  cv::RNG rng(23);
  const std::vector<std::pair<int, int>> sizes = {{311, 239}, {33, 7}, {1, 1}, {1, 9},
                                                  {70, 1},    {2, 2},  {65, 3}};
  for (const auto& [w, h] : sizes) {
    for (const double invalid_fraction : {0.0, 0.1, 0.5, 1.0}) {
      // Piecewise smooth values (blocks plus noise) so that pieces of every size, shape and
      // nesting occur, with invalid pixels scattered over them.
      cv::Mat blocks((h + 4) / 5, (w + 4) / 5, CV_16SC1), src;
      rng.fill(blocks, cv::RNG::UNIFORM, -40, 40);
      cv::resize(blocks, src, cv::Size(w, h), 0, 0, cv::INTER_NEAREST);
      for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
          int16_t& v = src.at<int16_t>(y, x);
          v = static_cast<int16_t>(v * 16 + rng.uniform(-12, 13));
          if (rng.uniform(0.0, 1.0) < invalid_fraction) v = kSgmInvalidFixed;
        }
      }
      for (const auto& [max_size, max_diff] :
           std::vector<std::pair<int, int>>{{0, 16}, {1, 0}, {20, 8}, {100, 32}, {5000, 16}}) {
        cv::Mat want = src.clone();
        cv::filterSpeckles(want, kSgmInvalidFixed, max_size, max_diff);
        for (const int threads : {1, 2, 3, 7}) {
          cv::Mat got = src.clone();
          detail::FilterSpeckles(&got, max_size, max_diff, threads);
          ASSERT_EQ(cv::norm(got != want, cv::NORM_L1), 0)
              << w << "x" << h << " invalid " << invalid_fraction << " size " << max_size
              << " diff " << max_diff << " threads " << threads;
        }
      }
    }
  }
}

TEST(SgmScalarStages, MedianOfValidNeighbours) {
  cv::Mat src(3, 3, CV_16SC1, cv::Scalar(kSgmInvalidFixed));
  src.at<int16_t>(0, 0) = 10;
  src.at<int16_t>(0, 1) = 50;
  src.at<int16_t>(1, 1) = 20;
  src.at<int16_t>(2, 2) = 30;
  cv::Mat dst(3, 3, CV_16SC1);
  detail::MedianValid3x3(src, dst, 0, 3);
  EXPECT_EQ(dst.at<int16_t>(1, 1), 20);  // {10, 20, 30, 50}: lower median
  EXPECT_EQ(dst.at<int16_t>(0, 0), 20);  // {10, 50, 20}
  EXPECT_EQ(dst.at<int16_t>(2, 2), 20);  // {20, 30}
  EXPECT_EQ(dst.at<int16_t>(1, 0), kSgmInvalidFixed);
}

}  // namespace
}  // namespace linesight
