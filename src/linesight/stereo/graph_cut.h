// Graph-cut stereo: the slow global baseline (`gc` method).
//
// Minimises the Potts energy on the 4-connected pixel grid of the left image
//
//   E(f) = Σ_p D_p(f_p) + Σ_{p~q} w_pq · [f_p ≠ f_q]
//
// over integer disparities f by α-expansion (Boykov, Veksler & Zabih, PAMI 2001): cycles over all
// labels α, each move solving the binary "keep f_p or switch to α" problem exactly by a minimum
// cut. The binary energy is turned into a graph with Kolmogorov & Zabih's construction (PAMI 2004;
// Potts is regular, so no auxiliary nodes), and the cut is found by Boost.Graph's
// boykov_kolmogorov_max_flow on a compressed-sparse-row graph that is built once per image size;
// only the capacities are rewritten between moves.
//
//   data term    D_p(d) = min(BT or census cost, truncation): Birchfield–Tomasi
//   sampling-insensitive dissimilarity
//                (mean over colour channels) or the Hamming distance of census codes; a disparity
//                that points outside the right image costs the truncation value.
//   smoothness   w_pq = λ · (edge_multiplier if |I_p − I_q| < edge_threshold else 1): larger inside
//   uniform
//                regions, smaller across intensity edges, where depth discontinuities usually are.
//   start        winner-takes-all of D; a cycle that does not lower E ends the optimisation.
//   occlusions   optional: the right view is solved the same way (mirrored pair), pixels failing a
//   left-right
//                check are invalidated and, by default, filled with the farther (smaller) of the
//                nearest valid disparities on their row (occluded pixels belong to the background).
//
// All costs are integers (cost units = kGraphCutCostScale per grey level or census bit), so the
// optimisation is exact and deterministic. The expansion moves run serially: running moves of
// different labels or image strips in parallel would not be α-expansion any more. `threads` only
// lets the left and right views of the left-right check run side by side, which does not change the
// result.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "linesight/stereo/matcher.h"

namespace linesight {

// Integer cost units per grey level (Birchfield–Tomasi) or per census bit. BT is computed on
// doubled intensities (half-pixel interpolation stays integer), and 6 keeps the colour mean exact:
// 6 · mean of 3 channels = Σ_c 2·BT_c, and 6 · grey BT = 3 · 2·BT.
inline constexpr int kGraphCutCostScale = 6;

enum class GraphCutDataTerm {
  kBirchfieldTomasi,  // sampling-insensitive absolute difference (Birchfield & Tomasi, PAMI 1998)
  kCensus,  // Hamming distance of census codes over a square window (robust to gain/offset changes)
};

enum class GraphCutLabelOrder {
  kSequential,  // min_disparity, min_disparity + 1, ... in every cycle
  kRandom,  // a new permutation per cycle from a seeded generator (Boykov et al. recommend a random
            // order)
};

struct GraphCutOptions {
  // --- disparity range and threads (taken from MatcherOptions by the factory) ---
  int min_disparity = 0;     // smallest disparity searched (px); may be negative
  int num_disparities = 64;  // number of disparities = labels (px), in [1, 1024]
  int threads = 0;  // worker threads; 0 = all hardware threads. Only the two views of lr_check run
                    // in parallel.

  // --- data term ---
  // Census by default: it survives the gain/offset differences of real pairs (ETH3D terrace bad-1
  // 11 % with census, 55 % with BT) and is as good on Middlebury 2001 (tsukuba 2.2 %, venus 0.6 %).
  GraphCutDataTerm data_term = GraphCutDataTerm::kCensus;
  // BT on each colour channel, averaged, when the input is BGR; false = on grey.
  bool use_color = true;
  int census_window = 5;  // census window side (px, odd, 3..7; at most 48 bits)
  // Data cost saturation: grey levels for BT, bits for census (> 0). Limits the pull of occluded
  // and non-Lambertian pixels. (λ = 10, truncation = 10, edge 8 / ×2 were the best of a small
  // grid on tsukuba with BT and also serve census with a 5×5 window.)
  double truncation = 10;

  // --- smoothness term (same units as the data term) ---
  // Potts penalty λ for a disparity change between 4-neighbours across an intensity edge.
  double lambda = 10;
  // Neighbours whose intensities differ by less than this (grey levels; max over colour channels)
  // are "similar": their penalty is λ · edge_multiplier. 0 = every pair gets λ.
  int edge_threshold = 8;
  double edge_multiplier = 2;  // factor (>= 1) on λ between similar neighbours

  // --- optimisation ---
  // Maximum cycles over all labels (one expansion move per label each); the optimisation also
  // stops after a cycle that does not lower the energy. On Middlebury 2001-2003 a third cycle
  // lowers E by < 0.5 % and changes bad-1 by < 0.1 points, at 50 % more time.
  int iterations = 2;
  GraphCutLabelOrder label_order = GraphCutLabelOrder::kRandom;
  uint64_t seed = 1;  // seed of the random label order

  // --- occlusion handling ---
  bool lr_check =
      false;  // solve the right view too and invalidate pixels failing the left-right check
  int lr_max_diff = 0;  // largest allowed |d_left(x) − d_right(x − d_left(x))| (px), >= 0
  bool fill_occlusions =
      true;  // fill invalidated pixels from the background side (keeps the map dense)

  void Check() const;
  nlohmann::json ToJson() const;
};

struct GraphCutResult {
  cv::Mat
      disparity;  // CV_32FC1, final output (px, +inf invalid), what StereoMatcher::Compute returns
  cv::Mat raw_disparity;    // CV_32FC1, left labels after the expansion moves (dense)
  cv::Mat right_disparity;  // CV_32FC1, right-view labels (empty without lr_check)
  // Energy (cost units) of the winner-takes-all start and after every cycle, left view. Never
  // increases.
  std::vector<int64_t> energy_per_cycle;
  int cycles = 0;           // cycles run on the left view (<= iterations)
  int expansion_moves = 0;  // max-flow problems solved on the left view
  double seconds = 0;       // wall time of the whole computation
};

// The `gc` method. Safe to call from several threads at once: every call builds its own graphs (the
// expansion moves of one call reuse them), and the only threads it runs are its own std::thread
// for the right view. MatchResult::checked is the disparity itself.
class GraphCutMatcher final : public StereoMatcher {
 public:
  explicit GraphCutMatcher(const GraphCutOptions& options);
  ~GraphCutMatcher() override;

  std::string Name() const override { return "gc"; }
  MatchResult Compute(const cv::Mat& left, const cv::Mat& right) override;
  nlohmann::json Settings() const override;

  GraphCutResult ComputeDetailed(const cv::Mat& left, const cv::Mat& right);
  const GraphCutOptions& options() const { return options_; }

 private:
  GraphCutOptions options_;
};

// Reads GraphCutOptions from MatcherOptions (range, threads) and the --param keys of
// GraphCutParamDocs. Throws OptionError for invalid values.
GraphCutOptions ReadGraphCutOptions(const MatcherOptions& options, MatcherParams& params);

// The --param keys ReadGraphCutOptions reads, with GraphCutOptions' defaults.
std::vector<MatcherParamDoc> GraphCutParamDocs();

// Factory of the registry entry "gc" (matcher.cc).
std::unique_ptr<StereoMatcher> CreateGraphCutMatcher(const MatcherOptions& options,
                                                     MatcherParams& params);

namespace detail {

// The Potts energy of a labelling on a width × height 4-connected grid (row-major pixels).
// weight_right[p] is w between p and its right neighbour (ignored in the last column),
// weight_down[p] between p and the pixel below (ignored in the last row); data_costs[p] =
// D_p(labels[p]).
int64_t PottsEnergy(int width, int height, const std::vector<int32_t>& weight_right,
                    const std::vector<int32_t>& weight_down, const std::vector<int32_t>& labels,
                    const std::vector<int32_t>& data_costs);

// α-expansion moves on the Potts energy above, each solved exactly by one Boykov–Kolmogorov
// max-flow. The graph (pixels + source + sink, terminal links and both directions of every grid
// edge) is built once in the constructor; Expand only rewrites capacities.
class PottsExpansion {
 public:
  PottsExpansion(int width, int height, std::vector<int32_t> weight_right,
                 std::vector<int32_t> weight_down);
  ~PottsExpansion();
  PottsExpansion(const PottsExpansion&) = delete;
  PottsExpansion& operator=(const PottsExpansion&) = delete;

  // Current labelling and its data costs (one per pixel, >= 0).
  void SetLabeling(std::vector<int32_t> labels, std::vector<int32_t> data_costs);
  // The optimal expansion move of label alpha: every pixel keeps its label or takes alpha,
  // whichever combination minimises the energy. alpha_costs[p] = D_p(alpha) >= 0. Returns the
  // number of pixels that switched to alpha.
  int Expand(int32_t alpha, const int32_t* alpha_costs);

  int64_t Energy() const;
  const std::vector<int32_t>& labels() const { return labels_; }
  const std::vector<int32_t>& data_costs() const { return data_costs_; }

 private:
  struct Graph;
  int width_;
  int height_;
  std::vector<int32_t> weight_right_;
  std::vector<int32_t> weight_down_;
  std::vector<int32_t> labels_;
  std::vector<int32_t> data_costs_;
  std::unique_ptr<Graph> graph_;
};

}  // namespace detail
}  // namespace linesight
