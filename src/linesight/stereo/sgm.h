// Our own semi-global matcher (Hirschmüller, PAMI 2008) as a pipeline of named stages
// (CONVENTIONS.md §4):
//
//   census (window W×H, 64-bit codes) → matching cost (Hamming, optionally + truncated
//   Birchfield–Tomasi) → aggregate paths (4 or 8 directions, P1 / gradient-adapted P2, uint16 path
//   costs summed into one volume) → winner-takes-all with uniqueness ratio → subpixel (equiangular
//   or parabola) → left-right consistency (right disparity from the same aggregated volume) →
//   speckle filter → median 3×3.
//
// Every stage is a free function in linesight::detail (sgm_stages.h); the matcher owns the scratch
// buffers and reuses them between frames. The result is bit-identical for any thread count and any
// SIMD target (Highway runtime dispatch); tests compare every optimised stage with a naive scalar
// reference.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "linesight/stereo/matcher.h"

namespace linesight {

// Fixed-point disparity used between the WTA and the final float output (as OpenCV's DISP_SCALE):
// value = round(d * kSgmSubpixelScale). cv::filterSpeckles works on this int16 form.
inline constexpr int kSgmSubpixelScale = 16;

enum class SgmSubpixel {
  kNone,         // integer disparities
  kEquiangular,  // Shimizu & Okutomi's equiangular line fit: suits L1-like costs (census, BT)
  kParabola,     // parabola through the three costs around the minimum: suits quadratic costs
};

struct SgmOptions {
  // --- disparity range and threads (taken from MatcherOptions by the factory) ---
  int min_disparity = 0;     // smallest disparity searched (px); any value, may be negative
  int num_disparities = 64;  // number of disparities searched (px); any value in [1, 1024]
  int threads = 0;  // worker threads; 0 = all hardware threads. Results do not depend on it.

  // --- matching cost ---
  int census_width = 9;   // census window width (px, odd, 1..15); width*height - 1 <= 64 bits
  int census_height = 7;  // census window height (px, odd, 1..15)
  // Weight of the truncated Birchfield–Tomasi term added to the census Hamming distance, in eighths
  // of a cost unit per grey level: cost = hamming + (bt_weight * min(BT, bt_truncation)) / 8. 0 =
  // census only.
  int bt_weight = 0;
  int bt_truncation = 20;  // grey levels at which the BT term saturates (1..255)

  // --- path aggregation ---
  int num_paths = 8;  // 4 (horizontal + vertical) or 8 (plus the diagonals)
  // Defaults chosen once for all scenes on Middlebury 2001/2003 (bad-1 nonocc) and checked on
  // 2005/2006 half size (bad-2 nonocc); see the README. With census 9×7 (62 bits), p2 <= 192 keeps
  // path costs in uint8 (fast).
  int p1 = 28;   // penalty for a disparity change of ±1 px along a path (cost units)
  int p2 = 100;  // penalty for a larger disparity change (cost units), > p1
  // P2 adapted to the intensity step |ΔI| between a pixel and its predecessor on the path (grey
  // levels): P2' = max(p1 + 1, p2 * alpha / (alpha + |ΔI|)) in integer arithmetic, so depth
  // discontinuities, which usually coincide with intensity edges, are cheaper. 0 = constant P2.
  int p2_gradient_alpha = 30;

  // --- winner-takes-all and post-processing ---
  // Uniqueness ratio (percent): the winner is rejected when some disparity more than 1 px away has
  // an aggregated cost below best * 100 / (100 - uniqueness_ratio). 0 = off (the default: on the
  // dense Middlebury metrics the density it costs outweighs the errors it removes; the left-right
  // check does more).
  int uniqueness_ratio = 0;
  SgmSubpixel subpixel = SgmSubpixel::kEquiangular;
  // Largest allowed |d_left(x) - d_right(x - d_left(x))| between the integer left and right winners
  // (px); -1 = no left-right check.
  int lr_max_diff = 2;
  int speckle_window =
      100;  // largest blob (px) of similar disparities removed as a speckle; 0 = off
  double speckle_range = 2.0;  // largest disparity step (px) inside one speckle blob
  bool median = true;          // 3×3 median over valid neighbours of each valid pixel

  void Check() const;
  nlohmann::json ToJson() const;
};

// Why a pixel has no estimate (SgmResult::invalid_reason).
enum class SgmInvalid : uint8_t {
  kValid = 0,
  kNoCandidate = 1,  // every disparity of the range falls outside the right image
  kUniqueness = 2,   // rejected by the uniqueness ratio
  kLeftRight = 3,    // rejected by the left-right check
  kSpeckle = 4,      // removed by the speckle filter
};

struct SgmResult {
  cv::Mat
      disparity;  // CV_32FC1, final output (px, +inf invalid), what StereoMatcher::Compute returns
  cv::Mat raw_disparity;  // CV_32FC1, subpixel WTA of every pixel before uniqueness / LR / speckle
                          // / median (+inf only for kNoCandidate)
  cv::Mat
      right_disparity;  // CV_32FC1, integer WTA of the right view from the same volume (+inf: none)
  cv::Mat invalid_reason;  // CV_8UC1, SgmInvalid per pixel of `disparity`
  cv::Mat min_cost;        // CV_16UC1, aggregated cost of the winner
  // CV_16UC1, smallest aggregated cost more than 1 px from the winner (0xFFFF: none).
  cv::Mat second_cost;
};

// Per-pixel confidence of the winner, CV_32FC1 in [0, 1]: 1 - min_cost / second_cost (1 without a
// second candidate, 0 when both are 0 and where no disparity was a candidate). Computed on demand:
// nothing in the pipeline needs it.
cv::Mat SgmConfidence(const SgmResult& result);

// The `sgm` method. Runs its own std::threads (never OpenCV's pool). Not thread-safe (scratch
// buffers are reused); use one matcher per thread. MatchResult::checked is the disparity itself.
class SgmMatcher final : public StereoMatcher {
 public:
  explicit SgmMatcher(const SgmOptions& options);
  ~SgmMatcher() override;

  std::string Name() const override { return "sgm"; }
  MatchResult Compute(const cv::Mat& left, const cv::Mat& right) override;
  nlohmann::json Settings() const override;

  // The whole pipeline with its intermediate products (for refinement stages such as isgm).
  SgmResult ComputeDetailed(const cv::Mat& left, const cv::Mat& right);
  // The same into *result, reusing its buffers when they have the right size and type (their
  // contents are overwritten; give an empty or own SgmResult to keep an earlier one).
  void ComputeDetailed(const cv::Mat& left, const cv::Mat& right, SgmResult* result);

  const SgmOptions& options() const { return options_; }

 private:
  // `detailed` = false (Compute) leaves out the maps only SgmResult's readers need (raw and right
  // disparities, invalid reasons, costs): the disparity is the same.
  void Run(const cv::Mat& left, const cv::Mat& right, bool detailed, SgmResult* result);

  struct Scratch;
  SgmOptions options_;
  std::unique_ptr<Scratch> scratch_;
};

// Reads SgmOptions from MatcherOptions (range, threads) and the --param keys of SgmParamDocs; keys
// not given keep their value in `defaults` (isgm passes its own tuned set). Throws OptionError for
// invalid values.
SgmOptions ReadSgmOptions(const MatcherOptions& options, MatcherParams& params,
                          const SgmOptions& defaults = SgmOptions());

// The --param keys ReadSgmOptions reads, with their values in `defaults` as defaults.
std::vector<MatcherParamDoc> SgmParamDocs(const SgmOptions& defaults = SgmOptions());

// Factory of the registry entry "sgm" (matcher.cc).
std::unique_ptr<StereoMatcher> CreateSgmMatcher(const MatcherOptions& options,
                                                MatcherParams& params);

// Name of the SIMD target Highway dispatches the SGM kernels to on this machine (e.g. "AVX3_DL").
std::string SgmSimdTarget();

}  // namespace linesight
