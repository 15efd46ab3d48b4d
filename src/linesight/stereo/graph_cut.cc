#include "linesight/stereo/graph_cut.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <thread>
#include <utility>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "linesight/core/disparity.h"
#include "linesight/core/error.h"
#include "linesight/core/scoped_threads.h"
#include "linesight/core/timer.h"
#include "linesight/stereo/disparity_fill.h"

namespace linesight {

namespace {

const char* DataTermName(GraphCutDataTerm term) {
  return term == GraphCutDataTerm::kCensus ? "census" : "bt";
}

const char* LabelOrderName(GraphCutLabelOrder order) {
  return order == GraphCutLabelOrder::kRandom ? "random" : "sequential";
}

int32_t ToCostUnits(double value) {
  return static_cast<int32_t>(std::lround(value * kGraphCutCostScale));
}

}  // namespace

void GraphCutOptions::Check() const {
  CheckOption(num_disparities >= 1 && num_disparities <= 1024, "GraphCutOptions.num_disparities",
              num_disparities, "must be in [1, 1024]");
  CheckOption(min_disparity > -4096 && min_disparity < 4096, "GraphCutOptions.min_disparity",
              min_disparity, "must be in (-4096, 4096)");
  CheckOption(threads >= 0, "GraphCutOptions.threads", threads, "must be >= 0 (0 = all cores)");
  CheckOption(census_window >= 3 && census_window <= 7 && census_window % 2 == 1,
              "GraphCutOptions.census_window", census_window, "must be odd and in [3, 7]");
  CheckOption(std::isfinite(truncation) && truncation > 0 && truncation <= 1000,
              "GraphCutOptions.truncation", truncation,
              "must be in (0, 1000] (grey levels for bt, bits for census)");
  CheckOption(std::isfinite(lambda) && lambda >= 0 && lambda <= 10000, "GraphCutOptions.lambda",
              lambda, "must be in [0, 10000]");
  CheckOption(edge_threshold >= 0 && edge_threshold <= 256, "GraphCutOptions.edge_threshold",
              edge_threshold, "must be in [0, 256] grey levels (0 = no intensity adaptation)");
  CheckOption(std::isfinite(edge_multiplier) && edge_multiplier >= 1 && edge_multiplier <= 100,
              "GraphCutOptions.edge_multiplier", edge_multiplier, "must be in [1, 100]");
  CheckOption(iterations >= 1 && iterations <= 100, "GraphCutOptions.iterations", iterations,
              "must be in [1, 100] cycles");
  CheckOption(lr_max_diff >= 0, "GraphCutOptions.lr_max_diff", lr_max_diff, "must be >= 0 px");
}

nlohmann::json GraphCutOptions::ToJson() const {
  return {{"min_disparity", min_disparity},
          {"num_disparities", num_disparities},
          {"threads", threads},
          {"data", DataTermName(data_term)},
          {"color", use_color},
          {"census_window", census_window},
          {"truncation", truncation},
          {"lambda", lambda},
          {"edge_threshold", edge_threshold},
          {"edge_multiplier", edge_multiplier},
          {"iterations", iterations},
          {"order", LabelOrderName(label_order)},
          {"seed", seed},
          {"lr_check", lr_check},
          {"lr_max_diff", lr_max_diff},
          {"fill_occlusions", fill_occlusions}};
}

namespace {

// The images the data and smoothness terms look at: 1 or 3 channels of 8 bits, same size and
// channel count.
struct MatchingImages {
  cv::Mat left;
  cv::Mat right;
};

cv::Mat ToColor8(const cv::Mat& image) {
  if (image.channels() == 3) return image;
  cv::Mat bgr;
  cv::cvtColor(image, bgr, cv::COLOR_BGRA2BGR);
  return bgr;
}

MatchingImages PrepareImages(const cv::Mat& left, const cv::Mat& right,
                             const GraphCutOptions& options) {
  if (left.empty() || right.empty()) throw InputError("gc: empty input image");
  if (left.size() != right.size()) {
    throw InputError(fmt::format("gc: left ({}x{}) and right ({}x{}) images differ in size",
                                 left.cols, left.rows, right.cols, right.rows));
  }
  const bool color = options.use_color && left.channels() >= 3 && right.channels() >= 3;
  if (color && left.depth() == CV_8U && right.depth() == CV_8U)
    return {ToColor8(left), ToColor8(right)};
  return {ToGray8(left), ToGray8(right)};
}

// D_p(d) for every pixel of one disparity at a time, so no cost volume is stored.
class StereoDataCost {
 public:
  StereoDataCost(const MatchingImages& images, const GraphCutOptions& options)
      : width_(images.left.cols),
        height_(images.left.rows),
        truncation_(std::max(1, ToCostUnits(options.truncation))),
        census_(options.data_term == GraphCutDataTerm::kCensus) {
    if (census_) {
      cv::Mat left_gray = ToGray8(images.left), right_gray = ToGray8(images.right);
      left_census_ = Census(left_gray, options.census_window);
      right_census_ = Census(right_gray, options.census_window);
    } else {
      channels_ = images.left.channels();
      PrepareBt(images.left, left_);
      PrepareBt(images.right, right_);
    }
  }

  int truncation() const { return truncation_; }

  // out[p] = D_p(d), p row-major.
  void Slice(int d, int32_t* out) const {
    for (int y = 0; y < height_; ++y) {
      int32_t* row = out + static_cast<size_t>(y) * width_;
      const int x_begin = std::clamp(d, 0, width_);  // first x with x - d >= 0
      const int x_end =
          std::clamp(width_ + d, 0, width_);  // one past the last x with x - d < width
      std::fill(row, row + x_begin, truncation_);
      std::fill(row + std::max(x_begin, x_end), row + width_, truncation_);
      if (census_) {
        const uint64_t* l = left_census_.data() + static_cast<size_t>(y) * width_;
        const uint64_t* r = right_census_.data() + static_cast<size_t>(y) * width_;
        for (int x = x_begin; x < x_end; ++x) {
          row[x] = std::min(truncation_, kGraphCutCostScale * std::popcount(l[x] ^ r[x - d]));
        }
      } else {
        const size_t offset = static_cast<size_t>(y) * width_ * channels_;
        const Bt& l = left_;
        const Bt& r = right_;
        // Units: each channel contributes 2·BT_c; 3 channels sum to 6·mean BT, one channel is
        // scaled by 3.
        const int scale = channels_ == 1 ? 3 : 1;
        for (int x = x_begin; x < x_end; ++x) {
          int sum = 0;
          for (int c = 0; c < channels_; ++c) {
            const size_t i = offset + static_cast<size_t>(x) * channels_ + c;
            const size_t j = offset + static_cast<size_t>(x - d) * channels_ + c;
            const int left_to_right = std::max({0, l.value[i] - r.max[j], r.min[j] - l.value[i]});
            const int right_to_left = std::max({0, r.value[j] - l.max[i], l.min[i] - r.value[j]});
            sum += std::min(left_to_right, right_to_left);
          }
          row[x] = std::min(truncation_, sum * scale);
        }
      }
    }
  }

 private:
  // Doubled intensities and the doubled extremes of the linear interpolation over ±half a pixel.
  struct Bt {
    std::vector<int16_t> value, min, max;
  };

  void PrepareBt(const cv::Mat& image, Bt& bt) const {
    const size_t count = static_cast<size_t>(width_) * height_ * channels_;
    bt.value.resize(count);
    bt.min.resize(count);
    bt.max.resize(count);
    for (int y = 0; y < height_; ++y) {
      const uint8_t* row = image.ptr<uint8_t>(y);
      for (int x = 0; x < width_; ++x) {
        for (int c = 0; c < channels_; ++c) {
          const int v = row[x * channels_ + c];
          const int before = x > 0 ? row[(x - 1) * channels_ + c] : v;
          const int after = x + 1 < width_ ? row[(x + 1) * channels_ + c] : v;
          const size_t i = (static_cast<size_t>(y) * width_ + x) * channels_ + c;
          bt.value[i] = static_cast<int16_t>(2 * v);
          bt.min[i] = static_cast<int16_t>(std::min({2 * v, v + before, v + after}));
          bt.max[i] = static_cast<int16_t>(std::max({2 * v, v + before, v + after}));
        }
      }
    }
  }

  // Census codes (bit set where a window pixel is darker than the centre), border pixels
  // replicated.
  std::vector<uint64_t> Census(const cv::Mat& gray, int window) const {
    std::vector<uint64_t> codes(static_cast<size_t>(width_) * height_);
    const int r = window / 2;
    for (int y = 0; y < height_; ++y) {
      for (int x = 0; x < width_; ++x) {
        const uint8_t centre = gray.at<uint8_t>(y, x);
        uint64_t code = 0;
        for (int dy = -r; dy <= r; ++dy) {
          const uint8_t* row = gray.ptr<uint8_t>(std::clamp(y + dy, 0, height_ - 1));
          for (int dx = -r; dx <= r; ++dx) {
            if (dx == 0 && dy == 0) continue;
            code = (code << 1) | (row[std::clamp(x + dx, 0, width_ - 1)] < centre ? 1u : 0u);
          }
        }
        codes[static_cast<size_t>(y) * width_ + x] = code;
      }
    }
    return codes;
  }

  int width_;
  int height_;
  int channels_ = 1;
  int32_t truncation_;
  bool census_;
  Bt left_, right_;
  std::vector<uint64_t> left_census_, right_census_;
};

// Intensity-adaptive Potts weights of the left image: λ·edge_multiplier between similar neighbours,
// else λ.
void SmoothnessWeights(const cv::Mat& image, const GraphCutOptions& options,
                       std::vector<int32_t>& weight_right, std::vector<int32_t>& weight_down) {
  const int width = image.cols, height = image.rows, channels = image.channels();
  const int32_t across_edge = ToCostUnits(options.lambda);
  const int32_t similar = ToCostUnits(options.lambda * options.edge_multiplier);
  weight_right.assign(static_cast<size_t>(width) * height, 0);
  weight_down.assign(static_cast<size_t>(width) * height, 0);
  auto difference = [&](const uint8_t* a, const uint8_t* b) {
    int largest = 0;
    for (int c = 0; c < channels; ++c) largest = std::max(largest, std::abs(a[c] - b[c]));
    return largest;
  };
  for (int y = 0; y < height; ++y) {
    const uint8_t* row = image.ptr<uint8_t>(y);
    const uint8_t* below = y + 1 < height ? image.ptr<uint8_t>(y + 1) : nullptr;
    for (int x = 0; x < width; ++x) {
      const size_t p = static_cast<size_t>(y) * width + x;
      const uint8_t* here = row + x * channels;
      if (x + 1 < width) {
        weight_right[p] =
            difference(here, here + channels) < options.edge_threshold ? similar : across_edge;
      }
      if (below) {
        weight_down[p] =
            difference(here, below + x * channels) < options.edge_threshold ? similar : across_edge;
      }
    }
  }
}

struct ViewSolution {
  cv::Mat disparity;  // CV_32FC1, dense unless no label fits the image
  std::vector<int64_t> energy_per_cycle;
  int cycles = 0;
  int expansion_moves = 0;
};

// α-expansion on one view (the left image of `images` is the reference).
ViewSolution SolveView(const MatchingImages& images, const GraphCutOptions& options) {
  const int width = images.left.cols, height = images.left.rows;
  const size_t n = static_cast<size_t>(width) * height;
  ViewSolution solution;
  solution.disparity = cv::Mat(height, width, CV_32FC1, cv::Scalar(kInvalidDisparity));

  // Labels whose disparity leaves some pixel a match inside the right image; the others are never
  // used.
  std::vector<int32_t> labels;
  for (int label = 0; label < options.num_disparities; ++label) {
    const int d = options.min_disparity + label;
    if (d < width && d > -width) labels.push_back(label);
  }
  if (labels.empty()) return solution;

  const StereoDataCost data(images, options);
  std::vector<int32_t> weight_right, weight_down;
  SmoothnessWeights(images.left, options, weight_right, weight_down);

  // Winner-takes-all start (ties keep the smaller disparity).
  std::vector<int32_t> slice(n);
  std::vector<int32_t> start_labels(n, labels.front());
  std::vector<int32_t> start_costs(n, std::numeric_limits<int32_t>::max());
  for (int32_t label : labels) {
    data.Slice(options.min_disparity + label, slice.data());
    for (size_t p = 0; p < n; ++p) {
      if (slice[p] < start_costs[p]) {
        start_costs[p] = slice[p];
        start_labels[p] = label;
      }
    }
  }

  detail::PottsExpansion expansion(width, height, std::move(weight_right), std::move(weight_down));
  expansion.SetLabeling(std::move(start_labels), std::move(start_costs));
  solution.energy_per_cycle.push_back(expansion.Energy());

  // A move of alpha from the labelling its last move produced cannot lower the energy, so it is
  // skipped while no other move has changed a pixel since.
  int64_t total_switched = 0;
  std::vector<int64_t> switched_at_last_move(options.num_disparities, -1);
  std::mt19937_64 random(options.seed);
  std::vector<int32_t> order = labels;
  for (int cycle = 0; cycle < options.iterations; ++cycle) {
    if (options.label_order == GraphCutLabelOrder::kRandom) {
      // Fisher–Yates with an explicit index draw, so the order is the same with every standard
      // library.
      for (size_t i = order.size(); i > 1; --i) std::swap(order[i - 1], order[random() % i]);
    }
    for (int32_t alpha : order) {
      if (switched_at_last_move[alpha] == total_switched) continue;
      data.Slice(options.min_disparity + alpha, slice.data());
      total_switched += expansion.Expand(alpha, slice.data());
      switched_at_last_move[alpha] = total_switched;
      ++solution.expansion_moves;
    }
    ++solution.cycles;
    solution.energy_per_cycle.push_back(expansion.Energy());
    if (solution.energy_per_cycle.back() >=
        solution.energy_per_cycle[solution.energy_per_cycle.size() - 2])
      break;
  }

  const std::vector<int32_t>& result = expansion.labels();
  for (int y = 0; y < height; ++y) {
    float* row = solution.disparity.ptr<float>(y);
    for (int x = 0; x < width; ++x) {
      row[x] =
          static_cast<float>(options.min_disparity + result[static_cast<size_t>(y) * width + x]);
    }
  }
  return solution;
}

// Left-right check: a left pixel survives when the right view, at the pixel it points to, agrees
// within max_diff.
cv::Mat LeftRightCheck(const cv::Mat& left_disparity, const cv::Mat& right_disparity,
                       int max_diff) {
  cv::Mat checked = left_disparity.clone();
  const int width = left_disparity.cols;
  for (int y = 0; y < left_disparity.rows; ++y) {
    float* row = checked.ptr<float>(y);
    const float* right_row = right_disparity.ptr<float>(y);
    for (int x = 0; x < width; ++x) {
      if (!IsValidDisparity(row[x])) continue;
      const int xr = x - static_cast<int>(row[x]);
      if (xr < 0 || xr >= width || !IsValidDisparity(right_row[xr]) ||
          std::abs(right_row[xr] - row[x]) > static_cast<float>(max_diff)) {
        row[x] = kInvalidDisparity;
      }
    }
  }
  return checked;
}

}  // namespace

GraphCutMatcher::GraphCutMatcher(const GraphCutOptions& options) : options_(options) {
  options_.Check();
}

GraphCutMatcher::~GraphCutMatcher() = default;

MatchResult GraphCutMatcher::Compute(const cv::Mat& left, const cv::Mat& right) {
  const cv::Mat disparity = ComputeDetailed(left, right).disparity;
  return {disparity, disparity};
}

nlohmann::json GraphCutMatcher::Settings() const {
  nlohmann::json settings = options_.ToJson();
  settings["method"] = "gc";
  return settings;
}

GraphCutResult GraphCutMatcher::ComputeDetailed(const cv::Mat& left, const cv::Mat& right) {
  Stopwatch stopwatch;
  const MatchingImages images = PrepareImages(left, right, options_);
  GraphCutResult result;

  ViewSolution left_view, right_view;
  if (options_.lr_check) {
    // The right view is the left view of the mirrored pair (flip(right), flip(left)) with the same
    // range.
    MatchingImages mirrored;
    cv::flip(images.right, mirrored.left, 1);
    cv::flip(images.left, mirrored.right, 1);
    auto solve_right = [&] {
      right_view = SolveView(mirrored, options_);
      cv::flip(right_view.disparity, right_view.disparity, 1);
    };
    if (ResolveThreadCount(options_.threads) >= 2) {
      std::thread worker(solve_right);
      left_view = SolveView(images, options_);
      worker.join();
    } else {
      left_view = SolveView(images, options_);
      solve_right();
    }
  } else {
    left_view = SolveView(images, options_);
  }

  result.raw_disparity = left_view.disparity;
  result.energy_per_cycle = std::move(left_view.energy_per_cycle);
  result.cycles = left_view.cycles;
  result.expansion_moves = left_view.expansion_moves;
  if (options_.lr_check) {
    result.right_disparity = right_view.disparity;
    result.disparity =
        LeftRightCheck(left_view.disparity, right_view.disparity, options_.lr_max_diff);
    // Occluded pixels belong to the farther surface; rows the check left without any valid pixel
    // stay invalid.
    if (options_.fill_occlusions) {
      detail::FillFromBackground(&result.disparity, {.fill_empty_rows = false, .parallel = false});
    }
  } else {
    result.disparity = left_view.disparity.clone();
  }
  result.seconds = stopwatch.ElapsedMs() / 1000.0;
  return result;
}

std::vector<MatcherParamDoc> GraphCutParamDocs() {
  const GraphCutOptions d;
  return {
      {"data", "bt|census", DataTermName(d.data_term),
       "data term: Birchfield-Tomasi dissimilarity or census Hamming distance"},
      {"color", "bool", ParamDefault(d.use_color),
       "BT on each colour channel of BGR input (else grey)"},
      {"census_window", "int", ParamDefault(d.census_window), "census window side (px, odd, 3..7)"},
      {"truncation", "number", ParamDefault(d.truncation),
       "data cost saturation (grey levels for bt, bits for census; > 0)"},
      {"lambda", "number", ParamDefault(d.lambda),
       "Potts penalty for a disparity change between 4-neighbours across an edge"},
      {"edge_threshold", "int", ParamDefault(d.edge_threshold),
       "neighbours closer than this (grey levels) are similar and pay lambda * edge_multiplier; "
       "0 = all pay lambda"},
      {"edge_multiplier", "number", ParamDefault(d.edge_multiplier),
       "factor (>= 1) on lambda between similar neighbours"},
      {"iterations", "int", ParamDefault(d.iterations),
       "largest number of cycles over all labels (stops early when a cycle does not lower the "
       "energy)"},
      {"order", "random|sequential", LabelOrderName(d.label_order),
       "order of the expansion moves within a cycle"},
      {"seed", "int", ParamDefault(d.seed), "seed of the random label order (>= 0)"},
      {"lr_check", "bool", ParamDefault(d.lr_check),
       "solve the right view too and invalidate pixels failing the left-right check"},
      {"lr_max_diff", "int", ParamDefault(d.lr_max_diff),
       "largest allowed left-right difference (px, >= 0)"},
      {"fill_occlusions", "bool", ParamDefault(d.fill_occlusions),
       "with lr_check: fill invalidated pixels from the background side"},
  };
}

GraphCutOptions ReadGraphCutOptions(const MatcherOptions& options, MatcherParams& params) {
  GraphCutOptions gc;
  gc.min_disparity = options.min_disparity;
  gc.num_disparities = options.num_disparities;
  gc.threads = options.threads;
  gc.data_term = params.GetString("data", "census", {"bt", "census"}) == "census"
                     ? GraphCutDataTerm::kCensus
                     : GraphCutDataTerm::kBirchfieldTomasi;
  gc.use_color = params.GetBool("color", gc.use_color);
  gc.census_window = params.GetInt("census_window", gc.census_window);
  gc.truncation = params.GetDouble("truncation", gc.truncation);
  gc.lambda = params.GetDouble("lambda", gc.lambda);
  gc.edge_threshold = params.GetInt("edge_threshold", gc.edge_threshold);
  gc.edge_multiplier = params.GetDouble("edge_multiplier", gc.edge_multiplier);
  gc.iterations = params.GetInt("iterations", gc.iterations);
  gc.label_order = params.GetString("order", "random", {"random", "sequential"}) == "sequential"
                       ? GraphCutLabelOrder::kSequential
                       : GraphCutLabelOrder::kRandom;
  const int seed = params.GetInt("seed", static_cast<int>(gc.seed));
  CheckOption(seed >= 0, "GraphCutOptions.seed", seed, "must be >= 0");
  gc.seed = static_cast<uint64_t>(seed);
  gc.lr_check = params.GetBool("lr_check", gc.lr_check);
  gc.lr_max_diff = params.GetInt("lr_max_diff", gc.lr_max_diff);
  gc.fill_occlusions = params.GetBool("fill_occlusions", gc.fill_occlusions);
  gc.Check();
  return gc;
}

std::unique_ptr<StereoMatcher> CreateGraphCutMatcher(const MatcherOptions& options,
                                                     MatcherParams& params) {
  return std::make_unique<GraphCutMatcher>(ReadGraphCutOptions(options, params));
}

}  // namespace linesight
