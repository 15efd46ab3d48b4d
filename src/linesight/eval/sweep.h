// `linesight eval sweep`: one-at-a-time parameter study of the matchers.
//
// Every parameter is varied alone while the others stay at the centre point: for the SGBM family
// (sgbm, sgbm-wls) num-disp 16..112 (step 16), block 3..11 (odd) and uniqueness 5..15 around
// (num-disp 64, block 7, uniqueness 10); for isgm num-disp and its own key parameters p1, p2,
// superpixel_size and plane_inlier around its defaults (num-disp 64); for bm num-disp, block and
// uniqueness; for sgm num-disp, p1 and p2; for gc num-disp and lambda. The num-disp sweep replaces
// each scene's own search range (MatcherOptions::num_disparities) by the swept value, so scenes
// whose ground truth exceeds the searched range get worse: that is what the curve shows.
//
// Each point is scored like `eval stereo` on the headline region of each set (nonocc where the set
// has it): RMSE over estimated pixels (px), the headline dense bad-tau (%), bad-1 (%), density (%)
// and run time, averaged per set and then over sets.
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "linesight/eval/dataset.h"

namespace linesight {

class ProgressBar;

// The key of the num-disp sweep (not a matcher parameter: it sets MatcherOptions).
inline constexpr char kSweepNumDisparitiesKey[] = "num_disp";

// One swept parameter of one method.
struct SweepParameter {
  std::string method;               // factory name (CreateMatcher)
  std::string key;                  // matcher parameter key, or kSweepNumDisparitiesKey
  std::vector<std::string> values;  // swept values in order (numeric text)
  std::string centre;               // value held while other parameters are swept
};

// The study's parameters for `method` (see the file comment); empty for an unknown method.
std::vector<SweepParameter> DefaultSweepParameters(const std::string& method);
// The registered matchers (MatcherNames) that have a default study, in registry order.
std::vector<std::string> MethodsWithDefaultSweep();

struct SweepOptions {
  std::vector<std::string> methods = {"sgbm", "sgbm-wls", "isgm"};  // factory names
  // Swept parameters; empty = DefaultSweepParameters of every method in `methods`.
  std::vector<SweepParameter> parameters;
  int threads = 0;  // matcher threads, 0 = all cores

  void Check() const;
};

// One point of a curve: the averages over the scenes.
struct SweepPoint {
  std::string value;   // parameter value (text as passed to the matcher)
  double rmse = 0;     // px, over estimated pixels of the headline region
  double bad = 0;      // headline dense bad-tau, % (e.g. bad-1.0 nonocc)
  double bad1 = 0;     // dense bad-1.0 on the headline region, %
  double density = 0;  // %, pixels with an estimate
  double ms = 0;       // mean Compute time per scene
  int scenes = 0;      // scenes averaged
};

struct SweepCurve {
  std::string method, key;
  std::string centre;
  // The other parameters' values (the centre point), as key=value.
  std::map<std::string, std::string> fixed;
  std::vector<SweepPoint> points;  // one per value, in order
};

struct SweepReport {
  std::vector<SweepCurve> curves;        // in parameter order
  std::vector<std::string> scene_names;  // "set/scene" of the averaged scenes
  std::string bad_label;  // headline label ("bad-1.0 nonocc"; "headline bad" when sets differ)

  nlohmann::json ToJson() const;
  // One table per parameter (rows value, columns method x {RMSE, bad}).
  std::string ToMarkdown() const;
  // <dir>/sweep_rmse.svg and <dir>/sweep_bad.svg: one panel per parameter key, a line per method.
  // Returns the written file names (relative to `dir`).
  std::vector<std::string> WritePlots(const std::filesystem::path& dir) const;
};

// Runs the study on `scenes` (each loaded once). Identical settings are computed once (the centre
// point is shared by the curves of one method). Throws like RunEvalStereo. `progress` (may be null)
// advances once per (point, scene).
SweepReport RunSweep(const std::vector<SceneRef>& scenes, const SweepOptions& options,
                     ProgressBar* progress = nullptr);

// Number of (point, scene) runs RunSweep advances the progress by.
int64_t SweepSteps(const SweepOptions& options, size_t num_scenes);

}  // namespace linesight
