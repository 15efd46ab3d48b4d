#include "linesight/eval/real_ranging.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "linesight/core/disparity.h"
#include "linesight/core/error.h"
#include "linesight/core/progress.h"
#include "linesight/core/timer.h"
#include "linesight/eval/plot.h"
#include "linesight/ranging/ranging.h"
#include "linesight/ranging/ranging_settings.h"

namespace linesight {

namespace fs = std::filesystem;

void RealRegionOptions::Check() const {
  CheckOption(joint_relative > 0.0 && joint_relative < 0.5, "RealRegionOptions.joint_relative",
              joint_relative, "must be in (0, 0.5)");
  CheckOption(max_nearer_fraction >= 0.0 && max_nearer_fraction < 1.0,
              "RealRegionOptions.max_nearer_fraction", max_nearer_fraction, "must be in [0, 1)");
  CheckOption(min_region_pixels >= 16, "RealRegionOptions.min_region_pixels", min_region_pixels,
              "must be >= 16");
  CheckOption(min_fill > 0.0 && min_fill <= 1.0, "RealRegionOptions.min_fill", min_fill,
              "must be in (0, 1]");
  CheckOption(max_roi_fraction > 0.0 && max_roi_fraction <= 1.0,
              "RealRegionOptions.max_roi_fraction", max_roi_fraction, "must be in (0, 1]");
  CheckOption(min_patch_px >= 5, "RealRegionOptions.min_patch_px", min_patch_px, "must be >= 5");
  CheckOption(patch_px >= min_patch_px, "RealRegionOptions.patch_px", patch_px,
              "must be >= min_patch_px");
  CheckOption(max_objects >= 0, "RealRegionOptions.max_objects", max_objects, "must be >= 0");
  CheckOption(max_surfaces >= 0, "RealRegionOptions.max_surfaces", max_surfaces, "must be >= 0");
  CheckOption(truth_smoothing_px >= 0 && truth_smoothing_px <= 10,
              "RealRegionOptions.truth_smoothing_px", truth_smoothing_px, "must be in [0, 10]");
}

void RealRangingOptions::Check() const {
  regions.Check();
  pipeline.Check();
}

namespace {

bool HasMetricCalibration(const SceneRef& ref) {
  switch (ref.layout) {
    case DatasetLayout::kMiddlebury2014:
    case DatasetLayout::kEth3d:
      return fs::exists(ref.dir / "calib.txt");
    case DatasetLayout::kMiddlebury2005:
      return fs::exists(ref.dir / "dmin.txt");
    default:
      return false;
  }
}

// Smooth surfaces of the ground truth: 4-connected labels (1..n, 0 = not evaluated) over the
// pixels of `evaluate`, neighbours joined when their depths differ by at most `joint_relative`:
// disparities by at most joint_relative * (d + doffs).
cv::Mat SurfaceLabels(const cv::Mat& gt, const cv::Mat& evaluate, double joint_relative,
                      double doffs, int* count) {
  cv::Mat labels(gt.size(), CV_32S, cv::Scalar(0));
  std::vector<cv::Point> stack;
  int next = 0;
  for (int y0 = 0; y0 < gt.rows; ++y0) {
    for (int x0 = 0; x0 < gt.cols; ++x0) {
      if (!evaluate.at<uchar>(y0, x0) || labels.at<int>(y0, x0) != 0) continue;
      labels.at<int>(y0, x0) = ++next;
      stack.assign(1, {x0, y0});
      while (!stack.empty()) {
        const cv::Point p = stack.back();
        stack.pop_back();
        const float d = gt.at<float>(p);
        for (const cv::Point step :
             {cv::Point(1, 0), cv::Point(-1, 0), cv::Point(0, 1), cv::Point(0, -1)}) {
          const cv::Point q = p + step;
          if (q.x < 0 || q.y < 0 || q.x >= gt.cols || q.y >= gt.rows) continue;
          if (!evaluate.at<uchar>(q) || labels.at<int>(q) != 0) continue;
          if (std::abs(gt.at<float>(q) - d) > joint_relative * (d + doffs)) continue;
          labels.at<int>(q) = next;
          stack.push_back(q);
        }
      }
    }
  }
  *count = next;
  return labels;
}

// The truth of a region: the largest ground-truth disparity over the surface's pixels inside
// `roi`, each the mean over the surface's pixels of its (2r+1)^2 neighbourhood.
double NearestTruth(const cv::Mat& gt, const cv::Mat& surface, const cv::Rect& roi, int r) {
  double best = -std::numeric_limits<double>::infinity();
  for (int y = roi.y; y < roi.br().y; ++y) {
    for (int x = roi.x; x < roi.br().x; ++x) {
      if (!surface.at<uchar>(y, x)) continue;
      double sum = 0.0;
      int n = 0;
      for (int v = std::max(0, y - r); v <= std::min(gt.rows - 1, y + r); ++v) {
        for (int u = std::max(0, x - r); u <= std::min(gt.cols - 1, x + r); ++u) {
          if (!surface.at<uchar>(v, u)) continue;
          sum += gt.at<float>(v, u);
          ++n;
        }
      }
      best = std::max(best, sum / n);
    }
  }
  return best;
}

double DepthOf(const StereoScene& scene, double d) {
  return scene.baseline_m * scene.focal_px / (d + scene.doffs_px);
}

// The patch of side <= patch_px centred on the surface pixel farthest from the surface's outline
// (and the image border), or an empty rect when the largest fitting square is below min_patch_px.
cv::Rect SurfacePatch(const cv::Mat& surface, const RealRegionOptions& options) {
  cv::Mat padded;
  cv::copyMakeBorder(surface, padded, 1, 1, 1, 1, cv::BORDER_CONSTANT, cv::Scalar(0));
  cv::Mat distance;
  cv::distanceTransform(padded, distance, cv::DIST_C, 3);  // chessboard: squares fit exactly
  double max_distance = 0.0;
  cv::Point at;
  cv::minMaxLoc(distance, nullptr, &max_distance, nullptr, &at);
  at -= cv::Point(1, 1);
  const int half = std::min((options.patch_px - 1) / 2, int(max_distance) - 1);
  if (2 * half + 1 < options.min_patch_px) return {};
  return {at.x - half, at.y - half, 2 * half + 1, 2 * half + 1};
}

}  // namespace

std::vector<SceneRef> MetricScenes(const fs::path& root) {
  std::vector<SceneRef> out;
  for (const SceneRef& ref : FindScenes(root)) {
    if (HasMetricCalibration(ref)) out.push_back(ref);
  }
  return out;
}

std::vector<RealRegion> DeriveRealRegions(const StereoScene& scene,
                                          const RealRegionOptions& options) {
  options.Check();
  if (!(scene.focal_px > 0.0) || !(scene.baseline_m > 0.0)) {
    throw InputError(fmt::format("scene {}/{} has no metric calibration (focal length, baseline)",
                                 scene.ref.set, scene.ref.name));
  }
  const cv::Mat& gt = scene.ground_truth;
  const auto nonocc = scene.masks.find("nonocc");
  const cv::Mat& evaluate = nonocc != scene.masks.end() ? nonocc->second : scene.masks.at("all");
  int count = 0;
  const cv::Mat labels =
      SurfaceLabels(gt, evaluate, options.joint_relative, scene.doffs_px, &count);
  std::vector<int> area(size_t(count) + 1, 0);
  for (int y = 0; y < labels.rows; ++y) {
    for (int x = 0; x < labels.cols; ++x) ++area[size_t(labels.at<int>(y, x))];
  }
  std::vector<int> order;
  for (int label = 1; label <= count; ++label) {
    if (area[size_t(label)] >= options.min_region_pixels) order.push_back(label);
  }
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return area[size_t(a)] > area[size_t(b)]; });
  std::vector<RealRegion> objects, surfaces;
  for (const int label : order) {
    const cv::Mat surface = labels == label;
    std::vector<float> values;
    for (int y = 0; y < gt.rows; ++y) {
      for (int x = 0; x < gt.cols; ++x) {
        if (surface.at<uchar>(y, x)) values.push_back(gt.at<float>(y, x));
      }
    }
    std::nth_element(values.begin(), values.begin() + long(values.size() / 2), values.end());
    const float median = values[values.size() / 2];
    if (int(objects.size()) < options.max_objects) {
      const cv::Rect box = cv::boundingRect(surface);
      const cv::Rect roi = GrowRoi(box, gt.size());
      int nearer = 0;
      for (int y = roi.y; y < roi.br().y; ++y) {
        for (int x = roi.x; x < roi.br().x; ++x) {
          const float d = gt.at<float>(y, x);
          nearer += !surface.at<uchar>(y, x) && IsValidDisparity(d) && d >= median;
        }
      }
      const bool in_front = nearer <= options.max_nearer_fraction * roi.area();
      const double fill = double(area[size_t(label)]) / double(roi.area());
      const double roi_share = double(roi.area()) / double(gt.total());
      if (in_front && fill >= options.min_fill && roi_share <= options.max_roi_fraction) {
        RealRegion r;
        r.kind = "object";
        r.roi = roi;
        r.pixels = area[size_t(label)];
        r.truth_disparity_px = NearestTruth(gt, surface, roi, options.truth_smoothing_px);
        r.truth_m = DepthOf(scene, r.truth_disparity_px);
        objects.push_back(r);
      }
    }
    if (int(surfaces.size()) < options.max_surfaces) {
      const cv::Rect patch = SurfacePatch(surface, options);
      if (!patch.empty()) {
        RealRegion r;
        r.kind = "surface";
        r.roi = patch;
        r.pixels = patch.area();
        r.truth_disparity_px = NearestTruth(gt, surface, patch, options.truth_smoothing_px);
        r.truth_m = DepthOf(scene, r.truth_disparity_px);
        surfaces.push_back(r);
      }
    }
  }
  objects.insert(objects.end(), surfaces.begin(), surfaces.end());
  return objects;
}

namespace {

// One diagnosis line per region (RealRangingOptions::diagnose).
void DiagnoseRegion(const StereoScene& scene, const RangingPipeline& chain,
                    const RangingFrame& frame, const RealRegion& region, const RangeResult& result,
                    std::FILE* log) {
  const RangingOptions& ranging = chain.options().ranging;
  auto relative = [&](const RangeResult& r) {
    return r.ok() ? fmt::format("{:.4f} m ({:+.2f} %)", r.distance_m,
                                100.0 * (r.distance_m / region.truth_m - 1.0))
                  : fmt::format("none ({})", r.reason);
  };
  // The estimator alone: the ground truth (+inf where unknown, as StereoScene keeps it) as its
  // disparity map, no refinement on the images.
  const cv::Mat& truth = scene.ground_truth;
  const RangeResult on_truth = RangeObstacle(truth, chain.geometry(), region.roi, ranging);
  RangingOptions keep_thin = ranging;
  keep_thin.min_body_width_m = 0.0;
  RangeResult thin_kept =
      RangeObstacle(chain.RangingDisparity(frame), chain.geometry(), region.roi, keep_thin);
  chain.RefineSurface(frame, &thin_kept);
  // The matcher's median error over the ROI's pixels where both maps hold a disparity.
  const cv::Mat matched = chain.RangingDisparity(frame)(region.roi);
  const cv::Mat true_roi = truth(region.roi);
  std::vector<float> errors;
  for (int y = 0; y < matched.rows; ++y) {
    for (int x = 0; x < matched.cols; ++x) {
      const float m = matched.at<float>(y, x), t = true_roi.at<float>(y, x);
      if (IsValidDisparity(m) && IsValidDisparity(t)) errors.push_back(m - t);
    }
  }
  std::string matcher = "no pixel with both";
  if (!errors.empty()) {
    std::nth_element(errors.begin(), errors.begin() + long(errors.size() / 2), errors.end());
    matcher = fmt::format("{:+.2f} px over {} px", errors[errors.size() / 2], errors.size());
  }
  fmt::print(log,
             "{}/{} {} roi {},{},{},{}: truth {:.4f} m (d {:.2f} px), measured {}, the estimator "
             "on the truth {}, thin structures kept {}, matcher median error {}\n",
             scene.ref.set, scene.ref.name, region.kind, region.roi.x, region.roi.y,
             region.roi.width, region.roi.height, region.truth_m, region.truth_disparity_px,
             relative(result), relative(on_truth), relative(thin_kept), matcher);
}

}  // namespace

RealRangingReport RunRealRangingStudy(const RealRangingOptions& options, ProgressBar* progress,
                                      std::FILE* log) {
  options.Check();
  Stopwatch watch;
  const std::vector<SceneRef> refs = MetricScenes(options.root);
  if (refs.empty()) {
    throw InputError(fmt::format(
        "{}: no scene with a metric calibration (Middlebury 2014 / ETH3D calib.txt, Middlebury "
        "2005/2006 dmin.txt)",
        options.root.string()));
  }
  RealRangingReport report;
  for (const SceneRef& ref : refs) {
    const StereoScene scene = LoadScene(ref);
    const std::vector<RealRegion> regions = DeriveRealRegions(scene, options.regions);
    report.scenes.push_back(ref.set + "/" + ref.name);
    if (progress) progress->Advance(1, ref.name);
    if (regions.empty()) continue;
    // The working range: the depths of the truth, widened by 10 % on each side.
    double d_min = std::numeric_limits<double>::infinity(), d_max = -d_min;
    for (int y = 0; y < scene.ground_truth.rows; ++y) {
      for (int x = 0; x < scene.ground_truth.cols; ++x) {
        const float d = scene.ground_truth.at<float>(y, x);
        if (!IsValidDisparity(d) || !scene.masks.at("all").at<uchar>(y, x)) continue;
        d_min = std::min(d_min, double(d));
        d_max = std::max(d_max, double(d));
      }
    }
    RangingPipelineOptions pipeline = options.pipeline;
    pipeline.input_rectified = true;
    pipeline.min_depth_m = DepthOf(scene, d_max) / 1.1;
    pipeline.max_depth_m = DepthOf(scene, std::max(d_min, 0.0)) * 1.1;
    const StereoCalibration calib =
        RectifiedPinholeCalibration(scene.left.size(), scene.focal_px, 0.5 * (scene.left.cols - 1),
                                    0.5 * (scene.left.rows - 1), scene.baseline_m, scene.doffs_px);
    const RangingPipeline chain(calib, pipeline);
    if (report.method.empty()) {
      report.method = chain.method();
      report.ranging_settings = RangingSettingsTable().ToJson(pipeline);
    }
    const RangingFrame frame = chain.Process(scene.left, scene.right);
    std::vector<cv::Rect> rois;
    for (const RealRegion& r : regions) rois.push_back(r.roi);
    const std::vector<RangeResult> results = chain.RangeRois(frame, rois);
    for (size_t i = 0; i < regions.size(); ++i) {
      report.regions.push_back({ref.set, ref.name, regions[i], results[i]});
      if (options.diagnose && log != nullptr) {
        DiagnoseRegion(scene, chain, frame, regions[i], results[i], log);
      }
    }
  }
  if (progress) progress->Finish();
  report.elapsed_s = watch.ElapsedMs() / 1000.0;
  return report;
}

RealRangingReport::Summary RealRangingReport::Summarise(const std::string& kind,
                                                        const std::string& set) const {
  Summary s;
  std::vector<float> errors;
  int covered = 0;
  for (const RealRegionResult& r : regions) {
    if ((!kind.empty() && r.region.kind != kind) || (!set.empty() && r.set != set)) continue;
    ++s.regions;
    if (!r.result.ok()) continue;
    const double e = r.relative_error();
    errors.push_back(float(std::abs(e)));
    s.mean += e;
    covered += std::abs(r.result.distance_m - r.region.truth_m) <= 2.0 * r.result.sigma_m;
  }
  s.measured = int(errors.size());
  if (errors.empty()) return s;
  s.mean /= double(errors.size());
  s.coverage = double(covered) / double(errors.size());
  std::sort(errors.begin(), errors.end());
  auto quantile = [&](double p) {
    const double at = p * double(errors.size() - 1);
    const size_t lo = size_t(std::floor(at));
    const size_t hi = std::min(errors.size() - 1, lo + 1);
    return errors[lo] + (at - double(lo)) * (errors[hi] - errors[lo]);
  };
  s.median_abs = quantile(0.5);
  s.p95_abs = quantile(0.95);
  return s;
}

namespace {

std::vector<std::string> SetsOf(const std::vector<RealRegionResult>& regions) {
  std::vector<std::string> sets;
  for (const RealRegionResult& r : regions) {
    if (std::find(sets.begin(), sets.end(), r.set) == sets.end()) sets.push_back(r.set);
  }
  return sets;
}

nlohmann::json SummaryJson(const RealRangingReport::Summary& s) {
  return {{"regions", s.regions},
          {"measured", s.measured},
          {"median_abs_relative", s.median_abs},
          {"p95_abs_relative", s.p95_abs},
          {"mean_relative", s.mean},
          {"coverage_2sigma", s.coverage}};
}

}  // namespace

std::string RealRangingReport::ToMarkdown() const {
  std::string out = fmt::format(
      "Ranging on real rectified pairs (method {}; {} scenes, {} regions from the ground truth; "
      "truth = the region's nearest surface):\n\n"
      "| set | kind | regions | measured | median abs % | p95 abs % | mean % | within 2 sigma % "
      "|\n|---|---|---|---|---|---|---|---|\n",
      method, scenes.size(), regions.size());
  std::vector<std::string> sets = SetsOf(regions);
  sets.push_back("");  // all
  for (const std::string& set : sets) {
    for (const std::string kind : {"object", "surface", ""}) {
      const Summary s = Summarise(kind, set);
      if (s.regions == 0) continue;
      out += fmt::format("| {} | {} | {} | {} | {:.2f} | {:.2f} | {:+.2f} | {:.0f} |\n",
                         set.empty() ? "**all**" : set, kind.empty() ? "all" : kind, s.regions,
                         s.measured, 100.0 * s.median_abs, 100.0 * s.p95_abs, 100.0 * s.mean,
                         100.0 * s.coverage);
    }
  }
  out +=
      "\n| scene | kind | roi | truth m | measured m | rel err % | sigma m |\n"
      "|---|---|---|---|---|---|---|\n";
  for (const RealRegionResult& r : regions) {
    const cv::Rect& roi = r.region.roi;
    out += fmt::format("| {}/{} | {} | {},{},{},{} | {:.4f} | ", r.set, r.scene, r.region.kind,
                       roi.x, roi.y, roi.width, roi.height, r.region.truth_m);
    out += r.result.ok() ? fmt::format("{:.4f} | {:+.2f} | {:.4f} |\n", r.result.distance_m,
                                       100.0 * r.relative_error(), r.result.sigma_m)
                         : fmt::format("no measurement: {} | | |\n", r.result.reason);
  }
  return out;
}

nlohmann::json RealRangingReport::ToJson() const {
  nlohmann::json j;
  j["method"] = method;
  j["ranging_settings"] = ranging_settings;
  j["scenes"] = scenes;
  j["elapsed_s"] = elapsed_s;
  j["summary"] = SummaryJson(Summarise());
  for (const std::string& set : SetsOf(regions))
    j["summary_by_set"][set] = SummaryJson(Summarise("", set));
  for (const std::string kind : {"object", "surface"}) {
    j["summary_by_kind"][kind] = SummaryJson(Summarise(kind));
  }
  j["regions"] = nlohmann::json::array();
  for (const RealRegionResult& r : regions) {
    nlohmann::json e = RangeResultToJson(r.result);
    e["set"] = r.set;
    e["scene"] = r.scene;
    e["kind"] = r.region.kind;
    e["truth_m"] = r.region.truth_m;
    e["truth_disparity_px"] = r.region.truth_disparity_px;
    e["region_pixels"] = r.region.pixels;
    if (r.result.ok()) e["relative_error"] = r.relative_error();
    j["regions"].push_back(e);
  }
  return j;
}

std::string RealRangingReport::ToSvg() const {
  LineChart chart;
  chart.title = fmt::format("ranging on real pairs ({})", method);
  chart.x_label = "share of regions";
  chart.y_label = "|relative error| (%), sorted";
  constexpr int kSteps = 21;
  for (int i = 0; i < kSteps; ++i) chart.x_values.push_back(double(i) / (kSteps - 1));
  for (const std::string& set : SetsOf(regions)) {
    std::vector<double> errors;
    for (const RealRegionResult& r : regions) {
      if (r.set == set && r.result.ok()) errors.push_back(100.0 * std::abs(r.relative_error()));
    }
    if (errors.empty()) continue;
    std::sort(errors.begin(), errors.end());
    PlotSeries s;
    s.name = set;
    for (const double x : chart.x_values) {
      s.y.push_back(errors[size_t(std::lround(x * double(errors.size() - 1)))]);
    }
    chart.series.push_back(s);
  }
  return chart.ToSvg();
}

}  // namespace linesight
