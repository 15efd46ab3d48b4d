#include "linesight/stereo/graph_cut.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "linesight/core/disparity.h"
#include "linesight/core/error.h"

namespace linesight {
namespace {

// ------------------------------------------------------------------------------------------------
// Options

TEST(GraphCutOptionsTest, DefaultsAreValid) { EXPECT_NO_THROW(GraphCutOptions{}.Check()); }

void ExpectValid(const std::function<void(GraphCutOptions&)>& change) {
  GraphCutOptions options;
  change(options);
  EXPECT_NO_THROW(options.Check());
}

void ExpectInvalid(const std::function<void(GraphCutOptions&)>& change, const std::string& field) {
  GraphCutOptions options;
  change(options);
  try {
    options.Check();
    ADD_FAILURE() << "no OptionError for " << field;
  } catch (const OptionError& error) {
    EXPECT_NE(std::string(error.what()).find("GraphCutOptions." + field), std::string::npos)
        << error.what();
  }
}

TEST(GraphCutOptionsTest, Boundaries) {
  ExpectValid([](auto& o) { o.num_disparities = 1; });
  ExpectValid([](auto& o) { o.num_disparities = 1024; });
  ExpectInvalid([](auto& o) { o.num_disparities = 0; }, "num_disparities");
  ExpectInvalid([](auto& o) { o.num_disparities = 1025; }, "num_disparities");
  ExpectValid([](auto& o) { o.min_disparity = -100; });
  ExpectInvalid([](auto& o) { o.min_disparity = 4096; }, "min_disparity");
  ExpectInvalid([](auto& o) { o.threads = -1; }, "threads");
  ExpectValid([](auto& o) { o.census_window = 3; });
  ExpectValid([](auto& o) { o.census_window = 7; });
  ExpectInvalid([](auto& o) { o.census_window = 1; }, "census_window");
  ExpectInvalid([](auto& o) { o.census_window = 4; }, "census_window");
  ExpectInvalid([](auto& o) { o.census_window = 9; }, "census_window");
  ExpectValid([](auto& o) { o.truncation = 1000; });
  ExpectInvalid([](auto& o) { o.truncation = 0; }, "truncation");
  ExpectInvalid([](auto& o) { o.truncation = 1001; }, "truncation");
  ExpectInvalid([](auto& o) { o.truncation = std::nan(""); }, "truncation");
  ExpectValid([](auto& o) { o.lambda = 0; });
  ExpectInvalid([](auto& o) { o.lambda = -1; }, "lambda");
  ExpectInvalid([](auto& o) { o.lambda = 10001; }, "lambda");
  ExpectValid([](auto& o) { o.edge_threshold = 0; });
  ExpectInvalid([](auto& o) { o.edge_threshold = -1; }, "edge_threshold");
  ExpectInvalid([](auto& o) { o.edge_threshold = 257; }, "edge_threshold");
  ExpectValid([](auto& o) { o.edge_multiplier = 1; });
  ExpectInvalid([](auto& o) { o.edge_multiplier = 0.99; }, "edge_multiplier");
  ExpectInvalid([](auto& o) { o.edge_multiplier = 101; }, "edge_multiplier");
  ExpectValid([](auto& o) { o.iterations = 1; });
  ExpectInvalid([](auto& o) { o.iterations = 0; }, "iterations");
  ExpectInvalid([](auto& o) { o.iterations = 101; }, "iterations");
  ExpectValid([](auto& o) { o.lr_max_diff = 0; });
  ExpectInvalid([](auto& o) { o.lr_max_diff = -1; }, "lr_max_diff");
}

TEST(GraphCutOptionsTest, FactoryReadsParamsAndRejectsUnknownKeys) {
  MatcherOptions options;
  options.min_disparity = 2;
  options.num_disparities = 20;
  options.params = {
      {"data", "census"}, {"lambda", "7.5"}, {"order", "sequential"}, {"lr_check", "true"}};
  auto matcher = CreateMatcher("gc", options);
  ASSERT_EQ(matcher->Name(), "gc");
  const nlohmann::json settings = matcher->Settings();
  EXPECT_EQ(settings["data"], "census");
  EXPECT_EQ(settings["lambda"], 7.5);
  EXPECT_EQ(settings["order"], "sequential");
  EXPECT_EQ(settings["lr_check"], true);
  EXPECT_EQ(settings["min_disparity"], 2);
  EXPECT_EQ(settings["num_disparities"], 20);

  options.params = {{"lamda", "3"}};
  EXPECT_THROW(CreateMatcher("gc", options), UsageError);
  options.params = {{"lambda", "-3"}};
  EXPECT_THROW(CreateMatcher("gc", options), OptionError);
  options.params = {{"data", "sad"}};
  EXPECT_THROW(CreateMatcher("gc", options), UsageError);
}

// ------------------------------------------------------------------------------------------------
// α-expansion against brute force

struct TinyPotts {
  int width = 0, height = 0, num_labels = 0;
  std::vector<int32_t> data;  // [p * num_labels + label]
  std::vector<int32_t> weight_right, weight_down;

  std::vector<int32_t> Costs(const std::vector<int32_t>& labels) const {
    std::vector<int32_t> costs(labels.size());
    for (size_t p = 0; p < labels.size(); ++p) costs[p] = data[p * num_labels + labels[p]];
    return costs;
  }
  std::vector<int32_t> Slice(int label) const {
    std::vector<int32_t> slice(static_cast<size_t>(width) * height);
    for (size_t p = 0; p < slice.size(); ++p) slice[p] = data[p * num_labels + label];
    return slice;
  }
  int64_t Energy(const std::vector<int32_t>& labels) const {
    return detail::PottsEnergy(width, height, weight_right, weight_down, labels, Costs(labels));
  }
  // Lowest energy over all 2^n binary "keep or take alpha" moves from `labels`.
  int64_t BestExpansionEnergy(const std::vector<int32_t>& labels, int alpha) const {
    const int n = width * height;
    int64_t best = std::numeric_limits<int64_t>::max();
    std::vector<int32_t> moved(labels);
    for (uint32_t mask = 0; mask < (1u << n); ++mask) {
      for (int p = 0; p < n; ++p) moved[p] = (mask >> p) & 1u ? alpha : labels[p];
      best = std::min(best, Energy(moved));
    }
    return best;
  }
};

TinyPotts RandomPotts(int width, int height, int num_labels, std::mt19937& random) {
  TinyPotts potts{width, height, num_labels, {}, {}, {}};
  std::uniform_int_distribution<int> data(0, 40), weight(0, 25);
  const size_t n = static_cast<size_t>(width) * height;
  for (size_t i = 0; i < n * num_labels; ++i) potts.data.push_back(data(random));
  for (size_t p = 0; p < n; ++p) {
    potts.weight_right.push_back(weight(random));
    potts.weight_down.push_back(weight(random));
  }
  return potts;
}

TEST(PottsExpansionTest, EveryMoveIsTheOptimalExpansionOnTinyGrids) {
  std::mt19937 random(12345);
  for (int trial = 0; trial < 24; ++trial) {
    const bool wide = trial % 2 == 0;
    TinyPotts potts = RandomPotts(wide ? 4 : 3, wide ? 3 : 3, 4, random);
    std::uniform_int_distribution<int> label(0, potts.num_labels - 1);
    std::vector<int32_t> labels(potts.width * potts.height);
    for (auto& l : labels) l = label(random);
    // One solver for the whole sequence: the graph is reused and only its capacities change.
    detail::PottsExpansion expansion(potts.width, potts.height, potts.weight_right,
                                     potts.weight_down);
    expansion.SetLabeling(labels, potts.Costs(labels));
    for (int move = 0; move < 2 * potts.num_labels; ++move) {
      const int alpha = label(random);
      const int64_t before = expansion.Energy();
      const int64_t best = potts.BestExpansionEnergy(expansion.labels(), alpha);
      const std::vector<int32_t> slice = potts.Slice(alpha);
      expansion.Expand(alpha, slice.data());
      ASSERT_EQ(expansion.Energy(), best)
          << "trial " << trial << " move " << move << " alpha " << alpha;
      EXPECT_LE(expansion.Energy(), before);
      // The solver's bookkeeping of data costs matches the labels.
      EXPECT_EQ(expansion.data_costs(), potts.Costs(expansion.labels()));
      EXPECT_EQ(expansion.Energy(), potts.Energy(expansion.labels()));
    }
  }
}

TEST(PottsExpansionTest, EnergyNeverIncreasesAndConvergesToALocalMinimum) {
  std::mt19937 random(7);
  TinyPotts potts = RandomPotts(13, 9, 6, random);
  std::vector<int32_t> labels(potts.width * potts.height, 0);
  detail::PottsExpansion expansion(potts.width, potts.height, potts.weight_right,
                                   potts.weight_down);
  expansion.SetLabeling(labels, potts.Costs(labels));
  int64_t energy = expansion.Energy();
  const int64_t start = energy;
  bool changed = true;
  int cycles = 0;
  while (changed && cycles < 20) {
    changed = false;
    for (int alpha = 0; alpha < potts.num_labels; ++alpha) {
      const std::vector<int32_t> slice = potts.Slice(alpha);
      expansion.Expand(alpha, slice.data());
      EXPECT_LE(expansion.Energy(), energy);
      changed |= expansion.Energy() < energy;
      energy = expansion.Energy();
    }
    ++cycles;
  }
  EXPECT_LT(cycles, 20);
  EXPECT_LT(energy, start);
  // Converged: no single-pixel relabelling lowers the energy (a weaker property than
  // expansion-optimality).
  std::vector<int32_t> probe = expansion.labels();
  for (size_t p = 0; p < probe.size(); ++p) {
    const int32_t keep = probe[p];
    for (int l = 0; l < potts.num_labels; ++l) {
      probe[p] = l;
      EXPECT_GE(potts.Energy(probe), energy);
    }
    probe[p] = keep;
  }
}

// ------------------------------------------------------------------------------------------------
// Matcher on synthetic scenes

cv::Mat RandomTexture(int rows, int cols, uint32_t seed) {
  cv::Mat texture(rows, cols, CV_8UC1);
  cv::RNG rng(seed);
  rng.fill(texture, cv::RNG::UNIFORM, 0, 256);
  return texture;
}

// left(x) = right(x - d) for a constant d.
void ConstantShiftPair(int rows, int cols, int d, cv::Mat& left, cv::Mat& right) {
  const cv::Mat texture = RandomTexture(rows, cols + d, 3);
  left = texture(cv::Rect(0, 0, cols, rows)).clone();
  right = texture(cv::Rect(d, 0, cols, rows)).clone();
}

int CountDifferent(const cv::Mat& disparity, float expected, int x_begin) {
  int different = 0;
  for (int y = 0; y < disparity.rows; ++y) {
    for (int x = x_begin; x < disparity.cols; ++x)
      different += disparity.at<float>(y, x) != expected;
  }
  return different;
}

TEST(GraphCutMatcherTest, RecoversAConstantShift) {
  cv::Mat left, right;
  ConstantShiftPair(24, 40, 5, left, right);
  GraphCutOptions options;
  options.num_disparities = 12;
  options.data_term = GraphCutDataTerm::kBirchfieldTomasi;
  GraphCutMatcher matcher(options);
  const GraphCutResult result = matcher.ComputeDetailed(left, right);
  ASSERT_EQ(result.disparity.type(), CV_32FC1);
  EXPECT_EQ(CountDifferent(result.disparity, 5.0f, 5),
            0);  // every pixel whose match is inside the right image
  EXPECT_GE(result.cycles, 1);
  EXPECT_GE(result.expansion_moves, 12);

  // A range starting below zero, and the census data term under a gain and offset change of the
  // right image.
  options.min_disparity = -4;
  options.num_disparities = 16;
  options.data_term = GraphCutDataTerm::kCensus;
  cv::Mat brighter;
  right.convertTo(brighter, CV_8U, 0.8, 20);
  GraphCutMatcher census(options);
  EXPECT_EQ(CountDifferent(census.Compute(left, brighter).disparity, 5.0f, 5), 0);
}

// Fronto-parallel step: background at disparity 3, a rectangle in front at 9; independent random
// textures.
struct StepScene {
  cv::Mat left, right, truth, occluded;
  static constexpr int kBackground = 3, kForeground = 9;
};

StepScene MakeStepScene(bool color) {
  const int rows = 30, cols = 48;
  const cv::Rect box(20, 8, 16, 14);  // in left-image coordinates
  const cv::Mat background = RandomTexture(rows, cols + StepScene::kBackground, 11);
  const cv::Mat foreground = RandomTexture(rows, cols, 12);
  StepScene scene;
  scene.left.create(rows, cols, CV_8UC1);
  scene.right.create(rows, cols, CV_8UC1);
  scene.truth.create(rows, cols, CV_32FC1);
  scene.occluded = cv::Mat::zeros(rows, cols, CV_8UC1);
  for (int y = 0; y < rows; ++y) {
    for (int x = 0; x < cols; ++x) {
      const bool front = box.contains({x, y});
      scene.left.at<uint8_t>(y, x) =
          front ? foreground.at<uint8_t>(y, x) : background.at<uint8_t>(y, x);
      scene.truth.at<float>(y, x) = front ? StepScene::kForeground : StepScene::kBackground;
      // Right pixel x sees the foreground point at left x + 9 when it is in the box, else the
      // background at x + 3.
      const bool right_front = box.contains({x + StepScene::kForeground, y});
      scene.right.at<uint8_t>(y, x) = right_front
                                          ? foreground.at<uint8_t>(y, x + StepScene::kForeground)
                                          : background.at<uint8_t>(y, x + StepScene::kBackground);
      // A background left pixel is hidden in the right view when the foreground covers x - 3 there.
      if (!front && box.contains({x - StepScene::kBackground + StepScene::kForeground, y})) {
        scene.occluded.at<uint8_t>(y, x) = 1;
      }
    }
  }
  if (color) {
    cv::Mat tint_left, tint_right;
    cv::cvtColor(scene.left, tint_left, cv::COLOR_GRAY2BGR);
    cv::cvtColor(scene.right, tint_right, cv::COLOR_GRAY2BGR);
    scene.left = tint_left;
    scene.right = tint_right;
  }
  return scene;
}

// Pixels of the non-occluded region right of the largest disparity whose estimate differs from the
// truth, leaving out pixels within edge_margin of a depth edge.
int CountErrors(const StepScene& scene, const cv::Mat& disparity, int edge_margin = 0) {
  int errors = 0;
  for (int y = 0; y < scene.truth.rows; ++y) {
    for (int x = StepScene::kForeground; x < scene.truth.cols; ++x) {
      if (scene.occluded.at<uint8_t>(y, x)) continue;
      bool near_edge = false;
      for (int dy = -edge_margin; dy <= edge_margin; ++dy) {
        for (int dx = -edge_margin; dx <= edge_margin; ++dx) {
          const int yy = std::clamp(y + dy, 0, scene.truth.rows - 1),
                    xx = std::clamp(x + dx, 0, scene.truth.cols - 1);
          near_edge |= scene.truth.at<float>(yy, xx) != scene.truth.at<float>(y, x);
        }
      }
      if (near_edge) continue;
      errors += disparity.at<float>(y, x) != scene.truth.at<float>(y, x);
    }
  }
  return errors;
}

TEST(GraphCutMatcherTest, RecoversAFrontoParallelStepExactly) {
  for (bool color : {false, true}) {
    const StepScene scene = MakeStepScene(color);
    GraphCutOptions options;
    options.num_disparities = 16;
    // BT compares single pixels, so the depth edge can be exact (census windows straddle it).
    options.data_term = GraphCutDataTerm::kBirchfieldTomasi;
    GraphCutMatcher matcher(options);
    const GraphCutResult result = matcher.ComputeDetailed(scene.left, scene.right);
    // Exact away from the depth edge; at a box corner the Potts boundary length does not change
    // when a corner pixel flips, so there the random texture decides (1-2 pixels).
    EXPECT_EQ(CountErrors(scene, result.disparity, /*edge_margin=*/1), 0) << "color " << color;
    EXPECT_LE(CountErrors(scene, result.disparity), 2) << "color " << color;
    ASSERT_GE(result.energy_per_cycle.size(), 2u);
    for (size_t i = 1; i < result.energy_per_cycle.size(); ++i) {
      EXPECT_LE(result.energy_per_cycle[i], result.energy_per_cycle[i - 1]);
    }
    EXPECT_LT(result.energy_per_cycle.back(), result.energy_per_cycle.front());
  }
}

TEST(GraphCutMatcherTest, LeftRightCheckFindsAndFillsOcclusions) {
  const StepScene scene = MakeStepScene(false);
  GraphCutOptions options;
  options.num_disparities = 16;
  options.data_term = GraphCutDataTerm::kBirchfieldTomasi;
  options.lr_check = true;
  options.fill_occlusions = false;
  const GraphCutResult checked = GraphCutMatcher(options).ComputeDetailed(scene.left, scene.right);
  ASSERT_FALSE(checked.right_disparity.empty());
  int occluded = 0, occluded_invalid = 0, visible_invalid = 0;
  for (int y = 0; y < scene.truth.rows; ++y) {
    for (int x = StepScene::kForeground; x < scene.truth.cols; ++x) {
      const bool invalid = !IsValidDisparity(checked.disparity.at<float>(y, x));
      if (scene.occluded.at<uint8_t>(y, x)) {
        ++occluded;
        occluded_invalid += invalid;
      } else {
        visible_invalid += invalid;
        if (!invalid) {
          EXPECT_EQ(checked.disparity.at<float>(y, x), scene.truth.at<float>(y, x));
        }
      }
    }
  }
  ASSERT_EQ(occluded, 14 * 6);
  EXPECT_GE(occluded_invalid, occluded * 3 / 4);
  EXPECT_LE(visible_invalid, 4);

  // Filled from the background side: the occluded band gets the background disparity, the map is
  // dense.
  options.fill_occlusions = true;
  const cv::Mat filled = GraphCutMatcher(options).Compute(scene.left, scene.right).disparity;
  EXPECT_EQ(DisparityDensity(filled), 100.0);
  int wrong = 0;
  for (int y = 0; y < scene.truth.rows; ++y) {
    for (int x = StepScene::kForeground; x < scene.truth.cols; ++x) {
      wrong += filled.at<float>(y, x) != scene.truth.at<float>(y, x);
    }
  }
  EXPECT_LE(wrong, 4);
}

TEST(GraphCutMatcherTest, IsDeterministicForAnySeedAndThreadCount) {
  const StepScene scene = MakeStepScene(true);
  GraphCutOptions options;
  options.num_disparities = 16;
  options.data_term = GraphCutDataTerm::kBirchfieldTomasi;
  options.seed = 99;
  options.lr_check = true;
  options.threads = 1;
  const GraphCutResult a = GraphCutMatcher(options).ComputeDetailed(scene.left, scene.right);
  options.threads = 2;
  const GraphCutResult b = GraphCutMatcher(options).ComputeDetailed(scene.left, scene.right);
  EXPECT_EQ(cv::norm(a.disparity, b.disparity, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a.right_disparity, b.right_disparity, cv::NORM_INF), 0.0);
  EXPECT_EQ(a.energy_per_cycle, b.energy_per_cycle);
  // Another order reaches the same optimum on this easy scene.
  options.label_order = GraphCutLabelOrder::kSequential;
  const GraphCutResult c = GraphCutMatcher(options).ComputeDetailed(scene.left, scene.right);
  EXPECT_LE(CountErrors(scene, c.raw_disparity), 2);
}

TEST(GraphCutMatcherTest, RejectsBadInputAndSkipsImpossibleLabels) {
  GraphCutMatcher matcher{GraphCutOptions{}};
  EXPECT_THROW(matcher.Compute(cv::Mat::zeros(10, 12, CV_8UC1), cv::Mat::zeros(10, 13, CV_8UC1)),
               InputError);
  EXPECT_THROW(matcher.Compute(cv::Mat(), cv::Mat()), InputError);
  EXPECT_THROW(matcher.Compute(cv::Mat::zeros(10, 12, CV_32FC1), cv::Mat::zeros(10, 12, CV_32FC1)),
               InputError);
  // No disparity of the range leaves a pixel inside the right image: nothing to estimate.
  GraphCutOptions options;
  options.min_disparity = 20;
  options.num_disparities = 4;
  const cv::Mat none = GraphCutMatcher(options)
                           .Compute(cv::Mat::zeros(6, 16, CV_8UC1), cv::Mat::zeros(6, 16, CV_8UC1))
                           .disparity;
  EXPECT_EQ(DisparityDensity(none), 0.0);
}

// ------------------------------------------------------------------------------------------------
// Tsukuba (Middlebury 2001), the classic graph-cut benchmark: bad-1.0 on non-occluded pixels of the
// full image.

TEST(GraphCutMatcherTest, TsukubaBad1NonOccluded) {
  const std::filesystem::path dir =
      std::filesystem::path(LINESIGHT_SHARED_DATA_DIR) / "middlebury-2001-2003/tsukuba";
  if (!std::filesystem::exists(dir / "imL.png")) GTEST_SKIP() << "no tsukuba data in " << dir;
  const cv::Mat left = cv::imread((dir / "imL.png").string(), cv::IMREAD_COLOR);
  const cv::Mat right = cv::imread((dir / "imR.png").string(), cv::IMREAD_COLOR);
  const cv::Mat truth = cv::imread((dir / "groundtruth.png").string(), cv::IMREAD_GRAYSCALE);
  const cv::Mat nonocc = cv::imread((dir / "nonocc.png").string(), cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(left.empty() || right.empty() || truth.empty() || nonocc.empty());
  GraphCutOptions options;
  options.num_disparities = 16;
  options.iterations = 2;
  const cv::Mat disparity = GraphCutMatcher(options).Compute(left, right).disparity;
  int evaluated = 0, bad = 0;
  for (int y = 0; y < truth.rows; ++y) {
    for (int x = 0; x < truth.cols; ++x) {
      if (nonocc.at<uint8_t>(y, x) != 255 || truth.at<uint8_t>(y, x) == 0) continue;
      ++evaluated;
      bad += !(std::abs(disparity.at<float>(y, x) - truth.at<uint8_t>(y, x) / 16.0f) <= 1.0f);
    }
  }
  ASSERT_GT(evaluated, 50000);
  const double bad_percent = 100.0 * bad / evaluated;
  RecordProperty("bad1_nonocc_percent", std::to_string(bad_percent));
  std::printf("tsukuba gc bad-1.0 nonocc = %.2f %%\n", bad_percent);
  // 2.23 % was measured with these settings (census; 1.89 % with BT;
  // published GC: 1.2-1.9 %).
  EXPECT_LE(bad_percent, 2.5);
}

}  // namespace
}  // namespace linesight
