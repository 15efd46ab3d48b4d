#include "linesight/eval/plate_study.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <opencv2/imgproc.hpp>

#include "linesight/core/atomic_file.h"
#include "linesight/core/error.h"
#include "linesight/core/progress.h"
#include "linesight/core/timer.h"
#include "linesight/eval/plot.h"
#include "linesight/eval/report.h"
#include "linesight/io/image_io.h"
#include "linesight/io/json_io.h"
#include "linesight/ranging/ranging_settings.h"
#include "linesight/stereo/matcher.h"

namespace linesight {

namespace fs = std::filesystem;

void PlateStudyOptions::Check() const {
  rig.Check();
  CheckOption(!shapes.empty(), "PlateStudyOptions.shapes", "empty", "needs at least one shape");
  CheckOption(!textures.empty(), "PlateStudyOptions.textures", "empty",
              "needs at least one texture");
  CheckOption(!distances.empty(), "PlateStudyOptions.distances", "empty",
              "needs at least one distance");
  for (double d : distances) {
    CheckOption(d >= 0.1 && d <= 100, "PlateStudyOptions.distances", d, "must be in [0.1, 100] m");
  }
  CheckOption(runs >= 1 && runs <= 1000, "PlateStudyOptions.runs", runs, "must be in [1, 1000]");
  CheckOption(noise_dn >= 0 && noise_dn <= 64, "PlateStudyOptions.noise_dn", noise_dn,
              "must be in [0, 64] DN");
  CheckOption(supersampling >= 1 && supersampling <= 8, "PlateStudyOptions.supersampling",
              supersampling, "must be in [1, 8]");
  pipeline.Check();
}

namespace {

PlateCell Summarise(const std::string& shape, const std::string& texture, double truth,
                    const std::vector<RangeResult>& results) {
  PlateCell c;
  static_cast<RangeRunStats&>(c) =
      SummariseRangeRuns(results, std::vector<double>(results.size(), truth));
  c.shape = shape;
  c.texture = texture;
  c.truth_m = truth;
  return c;
}

std::string TextureName(const std::string& file) { return fs::path(file).stem().string(); }

}  // namespace

PlateStudyReport RunPlateStudy(const PlateStudyOptions& options, ProgressBar* progress) {
  options.Check();
  Stopwatch watch;
  RangingPipelineOptions pipeline_options = options.pipeline;
  pipeline_options.input_rectified = true;
  const StereoCalibration calib = options.rig.Calibration();
  const RangingPipeline pipeline(calib, pipeline_options);
  const cv::Mat wall = ReadImage(options.texture_dir / options.background, ImageColor::kColor);

  PlateStudyReport report;
  report.method = pipeline.method();
  report.ranging_settings = RangingSettingsTable().ToJson(pipeline_options);
  report.machine = MachineDescription();
  report.background = TextureName(options.background);
  report.rig = options.rig;
  report.runs = options.runs;
  report.noise_dn = options.noise_dn;
  if (!options.save_dir.empty()) {
    fs::create_directories(options.save_dir);
    WriteStereoCalibration(options.save_dir / "calib.yml", calib);
  }
  for (const std::string& texture_file : options.textures) {
    const cv::Mat texture = ReadImage(options.texture_dir / texture_file, ImageColor::kColor);
    for (sim::PlateShape shape : options.shapes) {
      for (double distance : options.distances) {
        sim::PlateSceneSpec spec;
        spec.rig = options.rig;
        spec.shape = shape;
        spec.distance_m = distance;
        spec.plate_texture = texture;
        spec.background_texture = wall;
        spec.supersampling = options.supersampling;
        // Right of the axis, so that the box shows its left side from 1 m on and the object stays
        // inside the right view at 0.5 m.
        spec.centre_px = {0.70 * options.rig.image_size.width,
                          0.45 * options.rig.image_size.height};
        const sim::PlateRendering scene = sim::RenderPlateScene(spec);
        const cv::Rect roi = GrowRoi(scene.box, options.rig.image_size);
        std::vector<RangeResult> results;
        for (int run = 0; run < options.runs; ++run) {
          const std::uint64_t seed = options.seed * 1000003u + static_cast<std::uint64_t>(run) * 2;
          const cv::Mat left = sim::CapturePlateImage(scene.left, options.noise_dn, seed);
          const cv::Mat right = sim::CapturePlateImage(scene.right, options.noise_dn, seed + 1);
          const RangingFrame frame = pipeline.Process(left, right, cv::Range(roi.y, roi.br().y));
          results.push_back(pipeline.RangeRois(frame, {roi}).front());
          if (run == 0 && !options.save_dir.empty()) {
            const std::string stem = fmt::format("{}_{}_{:.2f}m", TextureName(texture_file),
                                                 sim::PlateShapeName(shape), distance);
            WriteImage(options.save_dir / (stem + "_left.png"), left);
            WriteImage(options.save_dir / (stem + "_right.png"), right);
            WriteJson(
                options.save_dir / (stem + ".json"),
                nlohmann::json{
                    {"true_distance_m", scene.distance_m},
                    {"roi", {roi.x, roi.y, roi.width, roi.height}},
                    {"object_box", {scene.box.x, scene.box.y, scene.box.width, scene.box.height}},
                    {"calibration", "calib.yml"}});
          }
          if (progress) {
            progress->Advance(1, fmt::format("{} {} {:.1f} m", TextureName(texture_file),
                                             sim::PlateShapeName(shape), distance));
          }
        }
        report.cells.push_back(Summarise(sim::PlateShapeName(shape), TextureName(texture_file),
                                         scene.distance_m, results));
      }
    }
  }
  report.elapsed_s = watch.ElapsedMs() / 1000.0;
  return report;
}

std::string PlateStudyReport::ToMarkdown() const {
  std::string out = fmt::format(
      "Ranging on pairs from an independent renderer (textured planar faces, photographs as "
      "textures, wall `{}` behind inside the ROI); method {}, {} runs per cell, read noise {} DN, "
      "rig {}x{} f {} px B {} m; truth = nearest visible point of the object (min Z).\n\n",
      background, method, runs, noise_dn, rig.image_size.width, rig.image_size.height, rig.focal_px,
      rig.baseline_m);
  out +=
      "| shape | texture | true m | runs | measured | mean m | rel err % | mean abs rel % | std m "
      "| "
      "mean sigma m | within 2 sigma % |\n|---|---|---|---|---|---|---|---|---|---|---|\n";
  int within = 0, measured_cells = 0, covered_cells = 0;
  for (const PlateCell& c : cells) {
    if (c.measured == 0) {
      std::string reasons;
      for (const auto& [reason, n] : c.failures) reasons += fmt::format("{} ({}); ", reason, n);
      out += fmt::format("| {} | {} | {:.2f} | {} | 0 | no measurement: {} | | | | | |\n", c.shape,
                         c.texture, c.truth_m, c.runs, reasons);
      continue;
    }
    ++measured_cells;
    within += std::abs(c.relative_error()) <= 0.01;
    const double coverage = 100.0 * c.covered / c.measured;
    covered_cells += coverage >= 90.0;
    out += fmt::format(
        "| {} | {} | {:.3f} | {} | {} | {:.4f} | {:+.2f} | {:.2f} | {:.4f} | {:.4f} | {:.0f} |\n",
        c.shape, c.texture, c.truth_m, c.runs, c.measured, c.mean_m, 100.0 * c.relative_error(),
        100.0 * c.mean_abs_relative, c.std_m, c.mean_sigma_m, coverage);
  }
  out += fmt::format(
      "\n{} of {} cells measured; {} of them within ±1 % (mean of the runs); ±2σ coverage ≥ 90 % "
      "in {}. {:.0f} s on {}.\n",
      measured_cells, cells.size(), within, covered_cells, elapsed_s, machine);
  return out;
}

nlohmann::json PlateStudyReport::ToJson() const {
  nlohmann::json rows = nlohmann::json::array();
  for (const PlateCell& c : cells) {
    rows.push_back({{"shape", c.shape},
                    {"texture", c.texture},
                    {"true_m", c.truth_m},
                    {"runs", c.runs},
                    {"measured", c.measured},
                    {"mean_m", c.mean_m},
                    {"relative_error", c.relative_error()},
                    {"mean_abs_relative", c.mean_abs_relative},
                    {"std_m", c.std_m},
                    {"mean_sigma_m", c.mean_sigma_m},
                    {"within_2_sigma", c.covered},
                    {"no_measurement_reasons", c.failures}});
  }
  return {{"method", method},
          {"background", background},
          {"runs", runs},
          {"noise_dn", noise_dn},
          {"rig",
           {{"width", rig.image_size.width},
            {"height", rig.image_size.height},
            {"focal_px", rig.focal_px},
            {"baseline_m", rig.baseline_m}}},
          {"machine", machine},
          {"elapsed_s", elapsed_s},
          {"ranging_settings", ranging_settings},
          {"cells", rows}};
}

void PlateStudyReport::WritePlots(const fs::path& dir) const {
  std::vector<std::string> shapes, textures;
  std::vector<double> distances;
  for (const PlateCell& c : cells) {
    if (std::find(shapes.begin(), shapes.end(), c.shape) == shapes.end()) shapes.push_back(c.shape);
    if (std::find(textures.begin(), textures.end(), c.texture) == textures.end())
      textures.push_back(c.texture);
    if (std::find(distances.begin(), distances.end(), c.truth_m) == distances.end())
      distances.push_back(c.truth_m);
  }
  std::vector<LineChart> charts;
  for (const std::string& shape : shapes) {
    LineChart chart;
    chart.title = fmt::format("{} ({})", shape, method);
    chart.x_label = "true distance (m)";
    chart.y_label = "relative error of the mean (%)";
    // x = the cells' true distances (the same geometry, hence the same truths, for every texture).
    for (const std::string& texture : textures) {
      PlotSeries s;
      s.name = texture;
      std::vector<double> x;
      for (const PlateCell& c : cells) {
        if (c.shape != shape || c.texture != texture) continue;
        x.push_back(c.truth_m);
        s.y.push_back(c.measured > 0 ? 100.0 * c.relative_error()
                                     : std::numeric_limits<double>::quiet_NaN());
      }
      if (chart.x_values.empty()) chart.x_values = x;
      chart.series.push_back(s);
    }
    for (double bound : {1.0, -1.0}) {
      PlotSeries b;
      b.name = bound > 0 ? "+1 %" : "-1 %";
      b.dashed = true;
      b.y.assign(chart.x_values.size(), bound);
      chart.series.push_back(b);
    }
    charts.push_back(chart);
  }
  fs::create_directories(dir);
  WriteSvgPanels(dir / "plates.svg", charts, static_cast<int>(std::min<size_t>(charts.size(), 3)));
}

}  // namespace linesight
