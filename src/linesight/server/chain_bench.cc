#include "linesight/server/chain_bench.h"

#include <algorithm>
#include <chrono>
#include <map>
#include <optional>
#include <thread>

#include <fmt/format.h>

#include "linesight/acquire/frame_source.h"
#include "linesight/core/error.h"
#include "linesight/core/machine.h"
#include "linesight/core/timer.h"
#include "linesight/stereo/throughput_bench.h"

namespace linesight {
namespace {

double Median(std::vector<double> values) {
  if (values.empty()) return 0;
  const size_t mid = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + long(mid), values.end());
  return values[mid];
}

// The station's own loop with its stages overlapped: the time between publications after the
// warm-up, and the latency of each published frame.
void MeasureOverlapped(const cv::Mat& left, const cv::Mat& right,
                       const StereoCalibration& calibration, BaseStationOptions station_options,
                       const ChainBenchOptions& options, ChainBenchRow* row) {
  station_options.overlap = true;
  station_options.max_frames = options.warmup + options.frames;
  BaseStation station(RepeatedPairSource(left, right, calibration, "chain"), std::nullopt,
                      station_options);
  station.Start();
  std::vector<double> intervals, latency;
  std::optional<std::chrono::steady_clock::time_point> previous;
  for (int64_t last = -1; station.running() || station.Snapshot().frame_index > last;) {
    const int64_t index = station.WaitForFrame(last, 60.0);
    if (index <= last) continue;
    const auto now = std::chrono::steady_clock::now();
    const BaseStationSnapshot snap = station.Snapshot();
    if (index >= options.warmup) {
      if (previous) {
        intervals.push_back(std::chrono::duration<double, std::milli>(now - *previous).count() /
                            double(index - last));
      }
      latency.push_back(snap.stages.latency);
    }
    previous = now;
    last = index;
  }
  station.Stop();
  if (!station.error().empty()) throw InputError("bench --chain: " + station.error());
  row->overlapped_frame_ms = Median(intervals);
  row->overlapped_fps = row->overlapped_frame_ms > 0 ? 1000.0 / row->overlapped_frame_ms : 0;
  row->overlapped_latency_ms = Median(latency);
}

ChainBenchRow RunRow(const cv::Mat& left, const cv::Mat& right,
                     const StereoCalibration& calibration, const std::string& spec,
                     const ChainBenchOptions& options) {
  BaseStationOptions station_options = options.station;
  std::map<std::string, std::string> params;
  SplitBenchMethod(spec, &station_options.pipeline.method, &params);
  station_options.pipeline.params = params;
  station_options.max_frames = 0;
  BaseStation station(RepeatedPairSource(left, right, calibration, "chain"), std::nullopt,
                      station_options);
  for (int i = 0; i < options.warmup; ++i) station.Step();
  std::vector<double> frame_ms, grab, rectify, match, range, inspect, health, encode, latency;
  const long faults_before = MinorPageFaults();
  for (int i = 0; i < options.frames; ++i) {
    Stopwatch watch;
    station.Step();
    frame_ms.push_back(watch.ElapsedMs());
    const StageTimes s = station.Snapshot().stages;
    grab.push_back(s.grab);
    rectify.push_back(s.rectify);
    match.push_back(s.match);
    range.push_back(s.range);
    inspect.push_back(s.inspect);
    health.push_back(s.health);
    encode.push_back(s.encode);
    latency.push_back(s.latency);
  }
  const long faults = MinorPageFaults() - faults_before;
  ChainBenchRow row;
  row.method = spec;
  row.frames = options.frames;
  const nlohmann::json status = station.Status();
  row.searched_disparities = status["searched_disparities"][1].get<int>() -
                             status["searched_disparities"][0].get<int>() + 1;
  row.median.grab = Median(grab);
  row.median.rectify = Median(rectify);
  row.median.match = Median(match);
  row.median.range = Median(range);
  row.median.inspect = Median(inspect);
  row.median.health = Median(health);
  row.median.encode = Median(encode);
  row.median.latency = Median(latency);
  row.frame_ms = Median(frame_ms);
  row.fps = row.frame_ms > 0 ? 1000.0 / row.frame_ms : 0;
  row.match_mde_per_s =
      MdePerSecond(left.cols, left.rows, row.searched_disparities, row.median.match);
  row.page_faults_per_frame = double(faults) / options.frames;
  MeasureOverlapped(left, right, calibration, station_options, options, &row);
  return row;
}

}  // namespace

void ChainBenchOptions::Check() const {
  CheckOption(!methods.empty(), "ChainBenchOptions.methods", "(empty)", "must name a method");
  CheckOption(warmup >= 0, "ChainBenchOptions.warmup", warmup, "must be >= 0");
  CheckOption(frames >= 1, "ChainBenchOptions.frames", frames, "must be >= 1");
  station.Check();
}

ChainBenchReport RunChainBench(const cv::Mat& left, const cv::Mat& right,
                               const StereoCalibration& calibration, const std::string& input,
                               const ChainBenchOptions& options,
                               const std::function<void(const ChainBenchRow&)>& progress) {
  options.Check();
  ChainBenchReport report;
  report.cpu = CpuModel();
  report.hardware_threads = int(std::thread::hardware_concurrency());
  report.image_size = left.size();
  report.input = input;
  report.finder = AutoFinderName(options.station.finder);
  report.warmup = options.warmup;
  for (const std::string& spec : options.methods) {
    report.rows.push_back(RunRow(left, right, calibration, spec, options));
    if (progress) progress(report.rows.back());
  }
  const auto sgbm = std::find_if(report.rows.begin(), report.rows.end(),
                                 [](const ChainBenchRow& r) { return r.method == "sgbm"; });
  if (sgbm != report.rows.end()) {
    for (ChainBenchRow& r : report.rows) {
      r.ratio_to_sgbm = sgbm->frame_ms / r.frame_ms;
      if (r.overlapped_frame_ms > 0) {
        r.overlapped_ratio_to_sgbm = sgbm->overlapped_frame_ms / r.overlapped_frame_ms;
      }
    }
  }
  report.peak_rss_mb = double(ProcStatusKb("VmHWM")) / 1024.0;
  return report;
}

std::string ChainBenchMarkdown(const ChainBenchReport& r) {
  std::string text = fmt::format(
      "Live chain (what `serve` does per frame) on {} ({}x{}), finder {}; {} ({} hardware "
      "threads); "
      "{} warm-up frames discarded; medians per stage (ms); peak RSS {:.0f} MiB\n\n"
      "| method | disparities | grab | rectify | match | range | inspect | health | encode | frame "
      "ms "
      "| fps "
      "| "
      "match MDE/s | page faults/frame | vs sgbm chain | overlapped: frame ms | fps | latency ms "
      "| vs sgbm |\n"
      "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
      r.input, r.image_size.width, r.image_size.height, r.finder, r.cpu, r.hardware_threads,
      r.warmup, r.peak_rss_mb);
  for (const ChainBenchRow& row : r.rows) {
    text += fmt::format(
        "| {} | {} | {:.1f} | {:.1f} | {:.1f} | {:.1f} | {:.1f} | {:.1f} | {:.1f} | {:.1f} | "
        "{:.1f} | "
        "{:.0f} | "
        "{:.0f} | {} | {:.1f} | {:.1f} | {:.0f} | {} |\n",
        row.method, row.searched_disparities, row.median.grab, row.median.rectify, row.median.match,
        row.median.range, row.median.inspect, row.median.health, row.median.encode, row.frame_ms,
        row.fps, row.match_mde_per_s, row.page_faults_per_frame,
        row.ratio_to_sgbm > 0 ? fmt::format("{:.2f}x", row.ratio_to_sgbm) : "-",
        row.overlapped_frame_ms, row.overlapped_fps, row.overlapped_latency_ms,
        row.overlapped_ratio_to_sgbm > 0 ? fmt::format("{:.2f}x", row.overlapped_ratio_to_sgbm)
                                         : "-");
  }
  return text;
}

nlohmann::json ChainBenchJson(const ChainBenchReport& r) {
  nlohmann::json rows = nlohmann::json::array();
  for (const ChainBenchRow& row : r.rows) {
    rows.push_back({{"method", row.method},
                    {"frames", row.frames},
                    {"searched_disparities", row.searched_disparities},
                    {"median_stage_ms", row.median.ToJson()},
                    {"frame_ms", row.frame_ms},
                    {"fps", row.fps},
                    {"match_mde_per_s", row.match_mde_per_s},
                    {"page_faults_per_frame", row.page_faults_per_frame},
                    {"ratio_to_sgbm", row.ratio_to_sgbm},
                    {"overlapped_frame_ms", row.overlapped_frame_ms},
                    {"overlapped_fps", row.overlapped_fps},
                    {"overlapped_latency_ms", row.overlapped_latency_ms},
                    {"overlapped_ratio_to_sgbm", row.overlapped_ratio_to_sgbm}});
  }
  return {{"cpu", r.cpu},
          {"hardware_threads", r.hardware_threads},
          {"image_size", {r.image_size.width, r.image_size.height}},
          {"input", r.input},
          {"finder", r.finder},
          {"warmup_frames", r.warmup},
          {"peak_rss_mb", r.peak_rss_mb},
          {"rows", rows}};
}

}  // namespace linesight
