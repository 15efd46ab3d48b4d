#include "linesight/stereo/sgm.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <thread>
#include <type_traits>
#include <vector>

#include <fmt/format.h>

#include "linesight/core/disparity.h"
#include "linesight/core/error.h"
#include "linesight/core/scoped_threads.h"
#include "linesight/stereo/sgm_stages.h"

namespace linesight {

namespace {

const char* SubpixelName(SgmSubpixel mode) {
  switch (mode) {
    case SgmSubpixel::kNone:
      return "none";
    case SgmSubpixel::kEquiangular:
      return "equiangular";
    case SgmSubpixel::kParabola:
      return "parabola";
  }
  return "?";
}

}  // namespace

void SgmOptions::Check() const {
  CheckOption(num_disparities >= 1 && num_disparities <= 1024, "SgmOptions.num_disparities",
              num_disparities, "must be in [1, 1024]");
  CheckOption(min_disparity >= -2000, "SgmOptions.min_disparity", min_disparity,
              "must be >= -2000");
  CheckOption(min_disparity + num_disparities <= 2000, "SgmOptions.min_disparity", min_disparity,
              "min_disparity + num_disparities must be <= 2000 (int16 fixed point)");
  CheckOption(threads >= 0, "SgmOptions.threads", threads, "must be >= 0 (0 = all cores)");
  CheckOption(census_width >= 1 && census_width <= 15 && census_width % 2 == 1,
              "SgmOptions.census_width", census_width, "must be odd and in [1, 15]");
  CheckOption(census_height >= 1 && census_height <= 15 && census_height % 2 == 1,
              "SgmOptions.census_height", census_height, "must be odd and in [1, 15]");
  CheckOption(census_width * census_height - 1 <= 64 && census_width * census_height >= 3,
              "SgmOptions.census_width", census_width,
              "census_width * census_height - 1 must be in [2, 64] (bits of the census code)");
  CheckOption(bt_weight >= 0 && bt_weight <= 64, "SgmOptions.bt_weight", bt_weight,
              "must be in [0, 64]");
  CheckOption(bt_truncation >= 1 && bt_truncation <= 255, "SgmOptions.bt_truncation", bt_truncation,
              "must be in [1, 255]");
  CheckOption(num_paths == 4 || num_paths == 8, "SgmOptions.num_paths", num_paths,
              "must be 4 or 8");
  CheckOption(p1 >= 0, "SgmOptions.p1", p1, "must be >= 0");
  CheckOption(p2 > p1, "SgmOptions.p2", p2, "must be > p1");
  const int max_cost = census_width * census_height - 1 + (bt_weight * 2 * bt_truncation) / 16;
  CheckOption(max_cost + p2 <= detail::kSgmMaxPathCost, "SgmOptions.p2", p2,
              "p2 + largest matching cost must be <= 4000 (16-bit path costs)");
  CheckOption(p2_gradient_alpha >= 0 && p2_gradient_alpha <= 100000, "SgmOptions.p2_gradient_alpha",
              p2_gradient_alpha, "must be in [0, 100000] (0 = constant P2)");
  CheckOption(uniqueness_ratio >= 0 && uniqueness_ratio <= 99, "SgmOptions.uniqueness_ratio",
              uniqueness_ratio, "must be in [0, 99] percent");
  CheckOption(lr_max_diff >= -1, "SgmOptions.lr_max_diff", lr_max_diff,
              "must be >= -1 (-1 = no check)");
  CheckOption(speckle_window >= 0, "SgmOptions.speckle_window", speckle_window,
              "must be >= 0 (0 = off)");
  CheckOption(speckle_range >= 0 && speckle_range <= 1000, "SgmOptions.speckle_range",
              speckle_range, "must be in [0, 1000] px");
}

nlohmann::json SgmOptions::ToJson() const {
  return {{"min_disparity", min_disparity},
          {"num_disparities", num_disparities},
          {"threads", threads},
          {"census_width", census_width},
          {"census_height", census_height},
          {"bt_weight", bt_weight},
          {"bt_truncation", bt_truncation},
          {"paths", num_paths},
          {"p1", p1},
          {"p2", p2},
          {"p2_alpha", p2_gradient_alpha},
          {"uniqueness", uniqueness_ratio},
          {"subpixel", SubpixelName(subpixel)},
          {"lr_max_diff", lr_max_diff},
          {"speckle_window", speckle_window},
          {"speckle_range", speckle_range},
          {"median", median}};
}

namespace detail {

namespace {
// Rounded num / den (den > 0), halves away from zero.
int RoundDivide(int num, int den) {
  return num >= 0 ? (num + den / 2) / den : -((-num + den / 2) / den);
}
}  // namespace

int SubpixelOffset(int mode, int c0, int c1, int c2) {
  int den = 0;
  if (mode == static_cast<int>(SgmSubpixel::kEquiangular)) {
    den = 2 * (std::max(c0, c2) - c1);
  } else if (mode == static_cast<int>(SgmSubpixel::kParabola)) {
    den = 2 * (c0 + c2 - 2 * c1);
  }
  if (den <= 0) return 0;
  return RoundDivide((c0 - c2) * kSgmSubpixelScale, den);
}

bool LeftRightConsistent(int x, int best, const int16_t* right_best, int width, int min_disparity,
                         int max_diff) {
  const int xr = x - min_disparity - best;
  if (xr < 0 || xr >= width) return false;
  const int right = right_best[xr];
  return right >= 0 && std::abs(right - best) <= max_diff;
}

void ParallelRanges(int n, int threads, const std::function<void(int, int)>& fn) {
  threads = std::max(1, std::min(threads, n));
  if (threads <= 1) {
    fn(0, n);
    return;
  }
  std::vector<std::thread> workers;
  for (int t = 1; t < threads; ++t) {
    workers.emplace_back([&, t] { fn(n * t / threads, n * (t + 1) / threads); });
  }
  fn(0, n / threads);
  for (auto& worker : workers) worker.join();
}

}  // namespace detail

struct SgmMatcher::Scratch {
  detail::AlignedVector<uint64_t> census_left, census_right;
  detail::SumVolume sum;
  detail::SweepScratch forward, backward;
  cv::Mat best, right_best;  // per pixel, from the WTA
  cv::Mat fixed, filtered, smoothed;
  SgmResult result;  // Compute()'s intermediate maps, reused between frames
};

SgmMatcher::SgmMatcher(const SgmOptions& options)
    : options_(options), scratch_(std::make_unique<Scratch>()) {
  options_.Check();
}

SgmMatcher::~SgmMatcher() = default;

MatchResult SgmMatcher::Compute(const cv::Mat& left, const cv::Mat& right) {
  // The intermediate maps stay allocated between frames (no page faults for 7 MB per frame at
  // 752x480); the returned disparity is a fresh buffer every time.
  SgmResult& reused = scratch_->result;
  reused.disparity = cv::Mat();
  Run(left, right, /*detailed=*/false, &reused);
  return {reused.disparity, reused.disparity};
}

nlohmann::json SgmMatcher::Settings() const {
  nlohmann::json settings = options_.ToJson();
  settings["method"] = "sgm";
  settings["simd_target"] = SgmSimdTarget();
  return settings;
}

SgmResult SgmMatcher::ComputeDetailed(const cv::Mat& left, const cv::Mat& right) {
  SgmResult result;
  ComputeDetailed(left, right, &result);
  return result;
}

void SgmMatcher::ComputeDetailed(const cv::Mat& left, const cv::Mat& right, SgmResult* result) {
  LS_CHECK(result != nullptr);
  Run(left, right, /*detailed=*/true, result);
}

void SgmMatcher::Run(const cv::Mat& left_input, const cv::Mat& right_input, bool detailed,
                     SgmResult* result_out) {
  if (left_input.empty() || right_input.empty()) throw InputError("sgm: input image is empty");
  if (left_input.size() != right_input.size()) {
    throw InputError(fmt::format("sgm: left image is {}x{} but right image is {}x{}",
                                 left_input.cols, left_input.rows, right_input.cols,
                                 right_input.rows));
  }
  cv::Mat left = ToGray8(left_input), right = ToGray8(right_input);
  if (!left.isContinuous()) left = left.clone();
  if (!right.isContinuous()) right = right.clone();
  const SgmOptions& o = options_;
  const int w = left.cols, h = left.rows, num = o.num_disparities, dmin = o.min_disparity;
  const int threads = ResolveThreadCount(o.threads);
  Scratch& s = *scratch_;

  // Stage 1: census transform of both images.
  const size_t pixels = static_cast<size_t>(w) * h;
  s.census_left.resize(pixels);
  s.census_right.resize(pixels);
  detail::ParallelRanges(h, threads, [&](int begin, int end) {
    detail::CensusTransform(left, o.census_width, o.census_height, begin, end,
                            s.census_left.data());
    detail::CensusTransform(right, o.census_width, o.census_height, begin, end,
                            s.census_right.data());
  });

  // Stages 2-4: matching cost and path aggregation (costs are computed on the fly per pixel inside
  // the sweeps), then winner-takes-all, uniqueness, subpixel and left-right check per row as soon
  // as it is final.
  detail::AggregationInput input;
  input.cost.width = w;
  input.cost.height = h;
  input.cost.min_disparity = dmin;
  input.cost.num_disparities = num;
  input.cost.census_bits = o.census_width * o.census_height - 1;
  input.cost.bt_weight = o.bt_weight;
  input.cost.bt_truncation = o.bt_truncation;
  input.cost.census_left = s.census_left.data();
  input.cost.census_right = s.census_right.data();
  input.cost.gray_left = left.ptr<uint8_t>();
  input.cost.gray_right = right.ptr<uint8_t>();
  input.num_paths = o.num_paths;
  input.p1 = o.p1;
  input.p2 = o.p2;
  input.p2_gradient_alpha = o.p2_gradient_alpha;

  SgmResult& result = *result_out;
  if (detailed) {
    result.raw_disparity.create(h, w, CV_32FC1);
    result.right_disparity.create(h, w, CV_32FC1);
    result.invalid_reason.create(h, w, CV_8UC1);
    result.min_cost.create(h, w, CV_16UC1);
    result.second_cost.create(h, w, CV_16UC1);
  } else {
    result.raw_disparity.release();
    result.right_disparity.release();
    result.invalid_reason.release();
    result.min_cost.release();
    result.second_cost.release();
  }
  s.best.create(h, w, CV_16SC1);
  s.right_best.create(h, w, CV_16SC1);
  s.fixed.create(h, w, CV_16SC1);

  const int subpixel = static_cast<int>(o.subpixel);
  // The per-pixel decisions of one row; kDetailed also writes the maps of SgmResult.
  auto finish_pixels = [&](auto detailed_tag, int y, const uint16_t* sum_row,
                           const detail::WtaRow& row) {
    constexpr bool kDetailed = decltype(detailed_tag)::value;
    float* raw = kDetailed ? result.raw_disparity.ptr<float>(y) : nullptr;
    float* right_out = kDetailed ? result.right_disparity.ptr<float>(y) : nullptr;
    uint8_t* reason = kDetailed ? result.invalid_reason.ptr<uint8_t>(y) : nullptr;
    int16_t* fixed = s.fixed.ptr<int16_t>(y);
    for (int x = 0; x < w; ++x) {
      if constexpr (kDetailed) {
        right_out[x] = row.right_best[x] < 0 ? kInvalidDisparity
                                             : static_cast<float>(dmin + row.right_best[x]);
      }
      // No disparity of the range maps into the right image: x - dmin - k in [0, w) has no solution
      // k.
      if (x - dmin < 0 || x - dmin - (num - 1) >= w) {
        if constexpr (kDetailed) {
          raw[x] = kInvalidDisparity;
          reason[x] = static_cast<uint8_t>(SgmInvalid::kNoCandidate);
        }
        fixed[x] = detail::kSgmInvalidFixed;
        continue;
      }
      const int best = row.best[x];
      const int best_cost = row.best_cost[x];
      SgmInvalid why = SgmInvalid::kValid;
      // second >= best_cost always, so a ratio of 0 rejects nothing (and then the WTA may skip the
      // second best).
      if (o.uniqueness_ratio > 0 &&
          static_cast<int64_t>(row.second_cost[x]) * (100 - o.uniqueness_ratio) <
              static_cast<int64_t>(best_cost) * 100) {
        why = SgmInvalid::kUniqueness;
      } else if (o.lr_max_diff >= 0 &&
                 !detail::LeftRightConsistent(x, best, row.right_best, w, dmin, o.lr_max_diff)) {
        why = SgmInvalid::kLeftRight;
      }
      if (!kDetailed && why != SgmInvalid::kValid) {
        fixed[x] = detail::kSgmInvalidFixed;
        continue;
      }
      const uint16_t* costs = sum_row + static_cast<size_t>(x) * s.sum.padded;
      int offset = 0;
      if (best > 0 && best < num - 1)
        offset = detail::SubpixelOffset(subpixel, costs[best - 1], best_cost, costs[best + 1]);
      const int value = (dmin + best) * kSgmSubpixelScale + offset;
      if constexpr (kDetailed) {
        raw[x] = static_cast<float>(value) / kSgmSubpixelScale;
        reason[x] = static_cast<uint8_t>(why);
      }
      fixed[x] = why == SgmInvalid::kValid ? static_cast<int16_t>(value) : detail::kSgmInvalidFixed;
    }
  };
  auto finish_row = [&](int y, const uint16_t* sum_row) {
    // One scratch per thread (the two sweeps finish rows concurrently), reused between rows.
    thread_local std::vector<uint16_t> right_scratch, row_costs;
    right_scratch.resize(detail::WtaScratchSize(w, num));
    detail::WtaRow row;
    row.best = s.best.ptr<int16_t>(y);
    row.right_best = s.right_best.ptr<int16_t>(y);
    if (detailed) {
      row.best_cost = result.min_cost.ptr<uint16_t>(y);
      row.second_cost = result.second_cost.ptr<uint16_t>(y);
    } else {
      row_costs.resize(2 * static_cast<size_t>(w));
      row.best_cost = row_costs.data();
      row.second_cost = o.uniqueness_ratio > 0 ? row_costs.data() + w : nullptr;
    }
    detail::WinnerTakesAllRow(sum_row, w, num, dmin, row, right_scratch.data());
    if (detailed) {
      finish_pixels(std::true_type(), y, sum_row, row);
    } else {
      finish_pixels(std::false_type(), y, sum_row, row);
    }
  };
  detail::AggregatePaths(input, std::min(threads, 2), &s.sum, &s.forward, &s.backward, finish_row);

  // Stage 5: speckle filter on the fixed-point map (cv::filterSpeckles' result, over row stripes in
  // parallel).
  const cv::Mat* map = &s.fixed;
  if (o.speckle_window > 0) {
    s.fixed.copyTo(s.filtered);  // reuses the buffer
    detail::FilterSpeckles(&s.filtered, o.speckle_window,
                           static_cast<int>(std::lround(o.speckle_range * kSgmSubpixelScale)),
                           threads);
    map = &s.filtered;
  }
  // Stage 6 and output, rows in parallel: speckle reasons, 3×3 median over valid neighbours, float
  // disparities.
  if (o.median) s.smoothed.create(h, w, CV_16SC1);
  result.disparity.create(h, w, CV_32FC1);
  detail::ParallelRanges(h, threads, [&](int begin, int end) {
    if (detailed && o.speckle_window > 0) {
      for (int y = begin; y < end; ++y) {
        const int16_t* before = s.fixed.ptr<int16_t>(y);
        const int16_t* after = s.filtered.ptr<int16_t>(y);
        uint8_t* reason = result.invalid_reason.ptr<uint8_t>(y);
        for (int x = 0; x < w; ++x) {
          if (before[x] != detail::kSgmInvalidFixed && after[x] == detail::kSgmInvalidFixed) {
            reason[x] = static_cast<uint8_t>(SgmInvalid::kSpeckle);
          }
        }
      }
    }
    if (o.median) detail::MedianValid3x3(*map, s.smoothed, begin, end);
    const cv::Mat& final_map = o.median ? s.smoothed : *map;
    for (int y = begin; y < end; ++y) {
      const int16_t* fixed = final_map.ptr<int16_t>(y);
      float* out = result.disparity.ptr<float>(y);
      for (int x = 0; x < w; ++x) {
        out[x] = fixed[x] == detail::kSgmInvalidFixed
                     ? kInvalidDisparity
                     : static_cast<float>(fixed[x]) / kSgmSubpixelScale;
      }
    }
  });
}

cv::Mat SgmConfidence(const SgmResult& result) {
  LS_CHECK(result.min_cost.type() == CV_16UC1 && result.second_cost.type() == CV_16UC1 &&
           result.invalid_reason.type() == CV_8UC1 &&
           result.min_cost.size() == result.second_cost.size() &&
           result.min_cost.size() == result.invalid_reason.size());
  cv::Mat confidence(result.min_cost.size(), CV_32FC1);
  for (int y = 0; y < confidence.rows; ++y) {
    const uint16_t* best = result.min_cost.ptr<uint16_t>(y);
    const uint16_t* second = result.second_cost.ptr<uint16_t>(y);
    const uint8_t* reason = result.invalid_reason.ptr<uint8_t>(y);
    float* out = confidence.ptr<float>(y);
    for (int x = 0; x < confidence.cols; ++x) {
      out[x] = reason[x] == static_cast<uint8_t>(SgmInvalid::kNoCandidate) ? 0.0f
               : second[x] == 0xFFFF
                   ? 1.0f
                   : (second[x] > 0 ? 1.0f - static_cast<float>(best[x]) / second[x] : 0.0f);
    }
  }
  return confidence;
}

SgmOptions ReadSgmOptions(const MatcherOptions& options, MatcherParams& params,
                          const SgmOptions& defaults) {
  SgmOptions o = defaults;
  o.min_disparity = options.min_disparity;
  o.num_disparities = options.num_disparities;
  o.threads = options.threads;
  o.census_width = params.GetInt("census_width", o.census_width);
  o.census_height = params.GetInt("census_height", o.census_height);
  o.bt_weight = params.GetInt("bt_weight", o.bt_weight);
  o.bt_truncation = params.GetInt("bt_truncation", o.bt_truncation);
  o.num_paths = params.GetInt("paths", o.num_paths);
  o.p1 = params.GetInt("p1", o.p1);
  o.p2 = params.GetInt("p2", o.p2);
  o.p2_gradient_alpha = params.GetInt("p2_alpha", o.p2_gradient_alpha);
  o.uniqueness_ratio = params.GetInt("uniqueness", o.uniqueness_ratio);
  const std::string subpixel =
      params.GetString("subpixel", SubpixelName(o.subpixel), {"none", "equiangular", "parabola"});
  o.subpixel = subpixel == "none"       ? SgmSubpixel::kNone
               : subpixel == "parabola" ? SgmSubpixel::kParabola
                                        : SgmSubpixel::kEquiangular;
  o.lr_max_diff = params.GetInt("lr_max_diff", o.lr_max_diff);
  o.speckle_window = params.GetInt("speckle_window", o.speckle_window);
  o.speckle_range = params.GetDouble("speckle_range", o.speckle_range);
  o.median = params.GetBool("median", o.median);
  o.Check();
  return o;
}

std::vector<MatcherParamDoc> SgmParamDocs(const SgmOptions& d) {
  return {
      {"census_width", "int", ParamDefault(d.census_width),
       "census window width (px, odd, 1..15; width*height - 1 <= 64 bits)"},
      {"census_height", "int", ParamDefault(d.census_height),
       "census window height (px, odd, 1..15)"},
      {"bt_weight", "int", ParamDefault(d.bt_weight),
       "weight of the truncated Birchfield-Tomasi term (eighths of a cost unit per grey level); "
       "0 = census only"},
      {"bt_truncation", "int", ParamDefault(d.bt_truncation),
       "grey levels at which the Birchfield-Tomasi term saturates (1..255)"},
      {"paths", "int", ParamDefault(d.num_paths), "aggregation directions: 4 or 8"},
      {"p1", "int", ParamDefault(d.p1), "penalty for a disparity change of +-1 px along a path"},
      {"p2", "int", ParamDefault(d.p2), "penalty for a larger disparity change (> p1)"},
      {"p2_alpha", "int", ParamDefault(d.p2_gradient_alpha),
       "P2 adapted to the intensity step: P2 * alpha / (alpha + |dI|); 0 = constant P2"},
      {"uniqueness", "int", ParamDefault(d.uniqueness_ratio),
       "uniqueness ratio (%) against disparities more than 1 px away; 0 = off"},
      {"subpixel", "none|equiangular|parabola", SubpixelName(d.subpixel),
       "subpixel fit of the winner (equiangular suits census)"},
      {"lr_max_diff", "int", ParamDefault(d.lr_max_diff),
       "largest left-right difference of the integer winners (px); -1 = no left-right check"},
      {"speckle_window", "int", ParamDefault(d.speckle_window),
       "largest blob of similar disparities removed as a speckle (px); 0 = off"},
      {"speckle_range", "number", ParamDefault(d.speckle_range),
       "largest disparity step inside one speckle blob (px)"},
      {"median", "bool", ParamDefault(d.median), "3x3 median over valid neighbours"},
  };
}

std::unique_ptr<StereoMatcher> CreateSgmMatcher(const MatcherOptions& options,
                                                MatcherParams& params) {
  return std::make_unique<SgmMatcher>(ReadSgmOptions(options, params));
}

std::string SgmSimdTarget() { return detail::DispatchedTargetName(); }

}  // namespace linesight
