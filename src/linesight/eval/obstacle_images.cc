#include "linesight/eval/obstacle_images.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "linesight/core/error.h"
#include "linesight/core/progress.h"
#include "linesight/core/timer.h"
#include "linesight/eval/metrics.h"
#include "linesight/eval/plot.h"
#include "linesight/ranging/ranging.h"
#include "linesight/stereo/matcher.h"

namespace linesight {
namespace fs = std::filesystem;

ObstacleCropGeometry ObstacleCropFor(const cv::Mat& ground_truth, const cv::Rect& box,
                                     int margin_px) {
  const cv::Rect image(0, 0, ground_truth.cols, ground_truth.rows);
  if (margin_px < 0) {
    throw InputError(fmt::format("obstacle crop: margin {} px must be >= 0", margin_px));
  }
  if (box.width <= 0 || box.height <= 0 || (box & image) != box) {
    throw InputError(
        fmt::format("obstacle crop: box {}x{}+{}+{} is empty or outside the {}x{} image", box.width,
                    box.height, box.x, box.y, image.width, image.height));
  }
  ObstacleCropGeometry g;
  g.evaluation_box = GrowRoiByPixels(box, margin_px, margin_px, image.size());
  double max_gt = 0;
  const cv::Mat gt = ground_truth(g.evaluation_box);
  for (int y = 0; y < gt.rows; ++y) {
    const float* row = gt.ptr<float>(y);
    for (int x = 0; x < gt.cols; ++x) {
      if (std::isfinite(row[x])) max_gt = std::max(max_gt, static_cast<double>(row[x]));
    }
  }
  const int needed = static_cast<int>(std::ceil(1.1 * max_gt)) + 1;
  g.num_disparities = std::max(16, (needed + 15) / 16 * 16);
  const int x0 = std::max(0, g.evaluation_box.x - g.num_disparities);
  g.crop = cv::Rect(x0, g.evaluation_box.y, g.evaluation_box.br().x - x0, g.evaluation_box.height);
  return g;
}

StereoScene CropObstacleScene(const cv::Mat& left, const cv::Mat& right,
                              const cv::Mat& ground_truth, const cv::Mat& obstacle_mask,
                              int obstacle_id, const cv::Rect& box, int margin_px,
                              const std::string& name) {
  if (left.size() != right.size() || left.size() != ground_truth.size() ||
      left.size() != obstacle_mask.size() || ground_truth.type() != CV_32FC1 ||
      obstacle_mask.type() != CV_8UC1) {
    throw InputError(
        "obstacle crop: left, right, ground truth (CV_32FC1) and obstacle mask (CV_8UC1) must "
        "have one size");
  }
  const ObstacleCropGeometry g = ObstacleCropFor(ground_truth, box, margin_px);
  StereoScene scene;
  scene.ref.set = kObstacleSetName;
  scene.ref.name = name;
  scene.ref.layout = DatasetLayout::kMiddlebury2001;  // unused: the scene is not loaded from disk
  scene.left = left(g.crop).clone();
  scene.right = right(g.crop).clone();
  scene.ground_truth = ground_truth(g.crop).clone();
  scene.min_disparity = 0;
  scene.num_disparities = g.num_disparities;
  cv::Mat all(g.crop.size(), CV_8UC1, cv::Scalar(0)), obstacle = all.clone();
  const cv::Rect eval_in_crop(g.evaluation_box.x - g.crop.x, 0, g.evaluation_box.width,
                              g.evaluation_box.height);
  for (int y = eval_in_crop.y; y < eval_in_crop.br().y; ++y) {
    const float* gt = scene.ground_truth.ptr<float>(y);
    const uint8_t* ids = obstacle_mask.ptr<uint8_t>(g.crop.y + y) + g.crop.x;
    for (int x = eval_in_crop.x; x < eval_in_crop.br().x; ++x) {
      if (!std::isfinite(gt[x])) continue;
      all.at<uint8_t>(y, x) = 255;
      if (ids[x] == obstacle_id) obstacle.at<uint8_t>(y, x) = 255;
    }
  }
  scene.masks["all"] = all;
  scene.masks["obstacle"] = obstacle;
  return scene;
}

void ObstacleImageOptions::Check() const {
  CheckOption(!obstacles.empty(), "ObstacleImageOptions.obstacles", "(empty)",
              "name at least one obstacle");
  CheckOption(supersampling >= 1 && supersampling <= 8, "ObstacleImageOptions.supersampling",
              supersampling, "must be in 1..8");
  CheckOption(margin_px >= 0, "ObstacleImageOptions.margin_px", margin_px, "must be >= 0");
}

std::vector<StereoScene> RenderObstacleScenes(const ObstacleImageOptions& options) {
  options.Check();
  sim::PowerLineSceneOptions scene_options;
  scene_options.seed = options.seed;
  scene_options.obstacles = options.obstacles;
  scene_options.sensor.supersampling = options.supersampling;
  scene_options.render_rectified_pair = true;
  const sim::PowerLineScene rendered = sim::RenderPowerLineScene(scene_options);
  std::vector<StereoScene> scenes;
  for (const sim::RenderedObstacle& o : rendered.obstacles) {
    if (o.visible_pixels == 0) continue;
    const std::string name =
        fmt::format("{}@{:g}m", sim::ObstacleTypeName(o.type), o.requested_distance_m);
    scenes.push_back(CropObstacleScene(rendered.rectified_left, rendered.rectified_right,
                                       rendered.disparity, rendered.obstacle_mask, o.id, o.box,
                                       options.margin_px, name));
  }
  return scenes;
}

void EvalObstaclesOptions::Check() const {
  CheckOption(!methods.empty(), "EvalObstaclesOptions.methods", "(empty)",
              "name at least one method");
  CheckOption(!noise.empty(), "EvalObstaclesOptions.noise", "(empty)",
              "name at least one noise setting");
  CheckOption(threads >= 0, "EvalObstaclesOptions.threads", threads, "must be >= 0");
}

namespace {

double MeanObstacleBad1(const std::vector<EvalStereoResult>& results, const std::string& method,
                        const std::string& noise) {
  double sum = 0;
  int n = 0;
  for (const auto& r : results) {
    if (r.method != method || r.noise != noise) continue;
    sum += r.regions.at("obstacle").bad[1];
    ++n;
  }
  return n ? sum / n : std::numeric_limits<double>::quiet_NaN();
}

}  // namespace

EvalObstaclesReport RunEvalObstacles(const std::vector<StereoScene>& scenes,
                                     const EvalObstaclesOptions& options, ProgressBar* progress) {
  options.Check();
  CheckStudyMethods(options.methods, options.params);
  EvalObstaclesReport report;
  for (const StereoScene& scene : scenes) {
    for (const NoiseSpec& noise : options.noise) {
      const std::string label = noise.Label();
      const std::string key = scene.ref.set + "/" + scene.ref.name + "/" + label;
      const auto [left, right] =
          AddPairNoise(scene.left, scene.right, noise, key, options.noise_seed);
      for (const std::string& method : options.methods) {
        const MatcherOptions m = StudyMatcherOptions(
            method, scene.min_disparity, scene.num_disparities, options.threads, options.params);
        auto matcher = CreateMatcher(method, m);
        Stopwatch watch;
        const cv::Mat disparity = matcher->Compute(left, right).disparity;
        EvalStereoResult r;
        r.ms = watch.ElapsedMs();
        r.set = scene.ref.set;
        r.scene = scene.ref.name;
        r.method = method;
        r.noise = label;
        r.width = scene.left.cols;
        r.height = scene.left.rows;
        r.min_disparity = scene.min_disparity;
        r.num_disparities = scene.num_disparities;
        r.mde_s = MdePerSecond(r.width, r.height, r.num_disparities, r.ms);
        r.settings = matcher->Settings();
        r.regions = ComputeRegionMetrics(disparity, scene.ground_truth, scene.masks);
        report.results.push_back(std::move(r));
        if (progress) progress->Advance(1, fmt::format("{} {} {}", scene.ref.name, label, method));
      }
    }
  }
  return report;
}

nlohmann::json EvalObstaclesReport::ToJson() const {
  nlohmann::json rows = nlohmann::json::array();
  for (const EvalStereoResult& r : results) {
    nlohmann::json regions = nlohmann::json::object();
    for (const auto& [name, metrics] : r.regions) regions[name] = metrics.ToJson();
    rows.push_back({{"scene", r.scene},
                    {"method", r.method},
                    {"noise", r.noise},
                    {"width", r.width},
                    {"height", r.height},
                    {"num_disparities", r.num_disparities},
                    {"ms", r.ms},
                    {"regions", regions},
                    {"settings", r.settings}});
  }
  return {{"set", kObstacleSetName}, {"results", rows}};
}

std::string EvalObstaclesReport::ToMarkdown() const {
  std::string out;
  const auto noises = UniqueInOrder(results, [](const EvalStereoResult& r) { return r.noise; });
  const auto methods = UniqueInOrder(results, [](const EvalStereoResult& r) { return r.method; });
  for (const std::string& noise : noises) {
    out += fmt::format("#### Obstacle crops{}\n\n", noise == "clean" ? "" : " — noise " + noise);
    out +=
        "| obstacle | crop (px) | method | obstacle bad-1 | obstacle bad-2 | obstacle RMSE | "
        "obstacle density | crop bad-1 | crop RMSE | ms "
        "|\n|---|---|---|---|---|---|---|---|---|---|"
        "\n";
    for (const EvalStereoResult& r : results) {
      if (r.noise != noise) continue;
      const DisparityMetrics& o = r.regions.at("obstacle");
      const DisparityMetrics& a = r.regions.at("all");
      out += fmt::format(
          "| {} | {}x{} ({} disp.) | {} | {:.2f} | {:.2f} | {:.2f} | {:.1f} | {:.2f} | {:.2f} | "
          "{:.1f} |\n",
          r.scene, r.width, r.height, r.num_disparities, r.method, o.bad[1], o.bad[2], o.rmse,
          o.density, a.bad[1], a.rmse, r.ms);
    }
    out += "\n";
  }
  out += "Mean bad-1 (%, dense) on the obstacle pixels over the obstacles:\n\n";
  out +=
      MethodByNoiseTable(methods, noises, [&](const std::string& method, const std::string& noise) {
        return MeanObstacleBad1(results, method, noise);
      });
  out += "\n";
  return out;
}

std::vector<std::string> EvalObstaclesReport::WritePlots(const fs::path& dir) const {
  const bool written = WriteNoiseChart(
      results, "Obstacle pixels: error vs image noise", "bad-1 on obstacle pixels (%)",
      [&](const std::string& method, const std::string& noise) {
        return MeanObstacleBad1(results, method, noise);
      },
      dir / "obstacles_noise.svg");
  if (!written) return {};
  return {"obstacles_noise.svg"};
}

}  // namespace linesight
