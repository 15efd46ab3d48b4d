// Ranging on real rectified pairs with metric calibration and dense ground truth: the data the
// ranging chain was never tuned on (`linesight eval ranging --real`).
//
// Scenes: every scene under the root that has a metric calibration (eval/dataset.h: Middlebury
// 2014 and ETH3D calib.txt, Middlebury 2005/2006 half size with dmin.txt). Regions come from the
// ground truth alone (DeriveRealRegions):
//  * the truth is cut into smooth surfaces: 4-connected pixels of the non-occluded ground truth
//  whose
//    disparities differ by at most joint_px;
//  * "object": a surface of at least min_region_pixels whose box grown like the studies' ROIs
//    (GrowRoi: 15 % + 6 px) holds (almost: max_nearer_fraction) nothing nearer than the surface's
//    median, i.e. a foreground object in front of what lies around it, filling at least min_fill
//    of an ROI no larger than max_roi_fraction of the image (a wall is no obstacle);
//  * "surface": a square patch (side patch_px, or the largest that fits) inside a surface, at the
//    point farthest from its outline: one surface and no depth edge, only matching noise.
// Truth of a region = its nearest surface: the largest disparity of the ground truth over the
// region's pixels after a (2 * truth_smoothing_px + 1)^2 mean over the same surface (Middlebury
// 2005/2006 stores whole full-size pixels, i.e. steps of 0.5 px at half size), converted with the
// scene's Z = B f / (d + doffs).
//
// Each scene is matched once by RangingPipeline (input_rectified, working range = the truth's
// depths widened by 10 %), then every region's ROI is ranged (RangeRois).
#pragma once

#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "linesight/eval/dataset.h"
#include "linesight/ranging/pipeline.h"

namespace linesight {

class ProgressBar;

struct RealRegionOptions {
  double joint_relative = 0.01;  // neighbours within this relative depth share a surface
  // An object's ROI may hold this share of pixels of other surfaces nearer than its median (the
  // fringe of the ground truth at its outline).
  double max_nearer_fraction = 0.05;
  int min_region_pixels = 1500;    // smallest surface taken as a region
  double min_fill = 0.2;           // an object fills at least this share of its ROI
  double max_roi_fraction = 0.25;  // an object's ROI covers at most this share of the image
  int patch_px = 61;               // side of a surface patch
  int min_patch_px = 21;           // smallest patch side
  int max_objects = 6;             // per scene, largest surfaces first
  int max_surfaces = 4;            // per scene, largest surfaces first
  int truth_smoothing_px = 2;      // radius of the mean before the truth's maximum

  void Check() const;
};

struct RealRegion {
  std::string kind;  // "object" or "surface"
  cv::Rect roi;      // what is ranged
  int pixels = 0;    // pixels of the surface inside the ROI
  double truth_disparity_px = 0.0;
  double truth_m = 0.0;
};

// The regions of one scene (see the file comment). Throws InputError when the scene has no metric
// calibration.
std::vector<RealRegion> DeriveRealRegions(const StereoScene& scene,
                                          const RealRegionOptions& options);

struct RealRangingOptions {
  std::filesystem::path root = LINESIGHT_SHARED_DATA_DIR;  // searched with FindScenes
  RealRegionOptions regions;
  RangingPipelineOptions pipeline;  // input_rectified and the working range are set per scene
  // Write one line per region to the study's log: the reading, the same estimator on the ground
  // truth (its own error without the matcher's), the reading with thin structures kept
  // (min_body_width_m = 0) and the matcher's median error over the ROI.
  bool diagnose = false;

  void Check() const;
};

struct RealRegionResult {
  std::string set, scene;
  RealRegion region;
  RangeResult result;
  double relative_error() const { return (result.distance_m - region.truth_m) / region.truth_m; }
};

struct RealRangingReport {
  std::string method;
  nlohmann::json ranging_settings;
  std::vector<std::string> scenes;  // "set/name", in the order ranged
  std::vector<RealRegionResult> regions;
  double elapsed_s = 0.0;

  // Of the measured regions (all of them or one kind): count, median and 95th percentile of
  // |relative error|, mean signed relative error, +-2 sigma coverage.
  struct Summary {
    int regions = 0, measured = 0;
    double median_abs = 0.0, p95_abs = 0.0, mean = 0.0, coverage = 0.0;
  };
  Summary Summarise(const std::string& kind = "", const std::string& set = "") const;

  std::string ToMarkdown() const;  // the summary table by set and kind, then every region
  nlohmann::json ToJson() const;
  // SVG: sorted |relative error| (%) against the share of regions, one line per set.
  std::string ToSvg() const;
};

// Throws InputError when the root holds no scene with a metric calibration. `log` (may be null)
// receives the diagnosis lines with options.diagnose.
RealRangingReport RunRealRangingStudy(const RealRangingOptions& options,
                                      ProgressBar* progress = nullptr, std::FILE* log = stderr);
// Scenes of `root` with a metric calibration (focal, baseline known), as RunRealRangingStudy
// ranges them.
std::vector<SceneRef> MetricScenes(const std::filesystem::path& root);

}  // namespace linesight
