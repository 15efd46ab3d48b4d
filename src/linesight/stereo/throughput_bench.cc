#include "linesight/stereo/throughput_bench.h"

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <regex>
#include <sstream>
#include <thread>

#include <fmt/format.h>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "linesight/core/disparity.h"
#include "linesight/core/error.h"
#include "linesight/core/key_value.h"
#include "linesight/core/machine.h"
#include "linesight/core/timer.h"
#include "linesight/stereo/matcher.h"
#include "linesight/stereo/sgm.h"

namespace linesight {
namespace {

// Seeded textured pair with a slanted disparity plane spanning 10 % .. 70 % of the range plus a
// nearer box, so every matcher does representative work (not a constant shift).
void MakeSyntheticPair(const BenchSize& size, cv::Mat* left, cv::Mat* right) {
  const int w = size.width, h = size.height, margin = size.num_disparities + 8;
  cv::RNG rng(20240611);
  cv::Mat noise(h / 2 + 2, (w + margin) / 2 + 2, CV_8UC1);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 256);
  cv::Mat texture;
  cv::resize(noise, texture, cv::Size(noise.cols * 2, noise.rows * 2), 0, 0, cv::INTER_LINEAR);
  left->create(h, w, CV_8UC1);
  right->create(h, w, CV_8UC1);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      left->at<uint8_t>(y, x) = texture.at<uint8_t>(y, x + margin);
      const bool box = x > w / 3 && x < w / 2 && y > h / 3 && y < 2 * h / 3;
      const double d = size.num_disparities * (0.1 + 0.5 * x / w + (box ? 0.1 : 0.0));
      // Right pixel x sees the left pixel x + d.
      right->at<uint8_t>(y, x) =
          texture.at<uint8_t>(y, std::min(x + margin + static_cast<int>(d), texture.cols - 1));
    }
  }
}

}  // namespace

void SplitBenchMethod(const std::string& spec, std::string* method,
                      std::map<std::string, std::string>* params) {
  const size_t colon = spec.find(':');
  *method = spec.substr(0, colon);
  if (method->empty()) throw UsageError(fmt::format("bench method '{}': no matcher name", spec));
  if (colon == std::string::npos) return;
  KeyValueSyntax syntax;
  syntax.separator = ':';
  syntax.allow_empty_value = false;
  syntax.allow_repeats = false;
  syntax.form = "key=value (NAME[:key=value...], e.g. isgm:paths=8)";
  const std::string flag = fmt::format("bench method '{}', item", spec);
  for (auto& [key, value] : ParseKeyValues(flag, {spec.substr(colon + 1)}, syntax)) {
    if (!params->emplace(key, value).second) {
      throw UsageError(fmt::format("{} '{}': set twice", flag, key));
    }
  }
}

namespace {

std::unique_ptr<StereoMatcher> CreateBenchMatcher(const std::string& spec, const BenchSize& size,
                                                  int threads) {
  MatcherOptions options;
  options.num_disparities = size.num_disparities;
  options.threads = threads;
  std::string method;
  SplitBenchMethod(spec, &method, &options.params);
  if (method == "sgbm-3way" || method == "sgbm-hh") {
    if (options.params.count("mode") != 0) {
      // (RunThroughputBench names the method in front of this message.)
      throw UsageError(fmt::format("{} sets the mode itself (use sgbm:mode=...)", method));
    }
    options.params["mode"] = method == "sgbm-3way" ? "3way" : "hh";
    return CreateMatcher("sgbm", options);
  }
  return CreateMatcher(method, options);
}

bool IsKnownMethod(const std::string& spec) {
  std::string method;
  std::map<std::string, std::string> params;
  SplitBenchMethod(spec, &method, &params);
  if (method == "sgbm-3way" || method == "sgbm-hh") return true;
  const auto names = MatcherNames();
  return std::find(names.begin(), names.end(), method) != names.end();
}

double Median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  const size_t n = values.size();
  return n % 2 == 1 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

// Runs in the forked child: returns the measurements as JSON.
nlohmann::json MeasureInChild(const BenchOptions& options, const std::string& method,
                              const BenchSize& size) {
  // Reset the RSS high-water mark to the current RSS (Linux >= 4.0), so VmHWM is this measurement's
  // own.
  { std::ofstream("/proc/self/clear_refs") << "5"; }
  const long start_kb = ProcStatusKb("VmRSS");
  cv::Mat left, right;
  if (options.left.empty()) {
    MakeSyntheticPair(size, &left, &right);
  } else {
    cv::resize(options.left, left, cv::Size(size.width, size.height), 0, 0, cv::INTER_AREA);
    cv::resize(options.right, right, cv::Size(size.width, size.height), 0, 0, cv::INTER_AREA);
  }
  auto matcher = CreateBenchMatcher(method, size, options.threads);
  cv::Mat disparity;
  for (int i = 0; i < options.warmup; ++i) disparity = matcher->Compute(left, right).disparity;
  std::vector<double> ms;
  for (int i = 0; i < options.runs; ++i) {
    Stopwatch watch;
    disparity = matcher->Compute(left, right).disparity;
    ms.push_back(watch.ElapsedMs());
  }
  const double density =
      100.0 * cv::countNonZero((disparity == disparity) & (disparity < kInvalidDisparity)) /
      static_cast<double>(disparity.total());
  return {
      {"ms", ms}, {"peak_kb", ProcStatusKb("VmHWM")}, {"start_kb", start_kb}, {"density", density}};
}

// One round of one method in a forked child: its run times (ms) into *ms, memory and density into
// *row. Returns false (row skipped with the reason) if the child failed.
bool MeasureForked(const BenchOptions& options, const std::string& method, const BenchSize& size,
                   BenchRow* out, std::vector<double>* ms) {
  BenchRow& row = *out;
  int fds[2];
  if (pipe(fds) != 0)
    throw std::runtime_error(fmt::format("bench: pipe failed: {}", std::strerror(errno)));
  const pid_t pid = fork();
  if (pid < 0)
    throw std::runtime_error(fmt::format("bench: fork failed: {}", std::strerror(errno)));
  if (pid == 0) {
    close(fds[0]);
    std::string text;
    try {
      text = MeasureInChild(options, method, size).dump();
    } catch (const std::exception& e) {
      text = nlohmann::json{{"error", e.what()}}.dump();
    }
    size_t written = 0;
    while (written < text.size()) {
      const ssize_t n = write(fds[1], text.data() + written, text.size() - written);
      if (n <= 0) break;
      written += static_cast<size_t>(n);
    }
    close(fds[1]);
    _exit(0);
  }
  close(fds[1]);
  std::string text;
  char buffer[4096];
  ssize_t n;
  while ((n = read(fds[0], buffer, sizeof(buffer))) > 0)
    text.append(buffer, static_cast<size_t>(n));
  close(fds[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  if (text.empty()) {
    row.skipped = true;
    row.note = fmt::format("child process died (status {})", status);
    return false;
  }
  const nlohmann::json j = nlohmann::json::parse(text);
  if (j.contains("error")) {
    row.skipped = true;
    row.note = j["error"].get<std::string>();
    return false;
  }
  *ms = j["ms"].get<std::vector<double>>();
  // Memory: the largest of the rounds (each child measures its own).
  row.peak_rss_mb = std::max(row.peak_rss_mb, j["peak_kb"].get<double>() / 1024.0);
  row.peak_added_mb = std::max(row.peak_added_mb,
                               (j["peak_kb"].get<double>() - j["start_kb"].get<double>()) / 1024.0);
  row.density = j["density"];
  return true;
}

}  // namespace

BenchSize ParseBenchSize(const std::string& text) {
  static const std::regex pattern(R"((\d+)x(\d+)x(\d+))");
  std::smatch m;
  if (!std::regex_match(text, m, pattern)) {
    throw UsageError(
        fmt::format("size '{}': expected WIDTHxHEIGHTxDISPARITIES, e.g. 752x480x128", text));
  }
  BenchSize size{std::stoi(m[1]), std::stoi(m[2]), std::stoi(m[3])};
  if (size.width < 16 || size.height < 16 || size.width > 16384 || size.height > 16384) {
    throw UsageError(fmt::format("size '{}': width and height must be in [16, 16384]", text));
  }
  if (size.num_disparities < 1 || size.num_disparities > 1024) {
    throw UsageError(fmt::format("size '{}': disparities must be in [1, 1024]", text));
  }
  return size;
}

void BenchOptions::Check() const {
  CheckOption(!sizes.empty(), "BenchOptions.sizes", sizes.size(), "must not be empty");
  CheckOption(!methods.empty(), "BenchOptions.methods", methods.size(), "must not be empty");
  CheckOption(runs >= 1, "BenchOptions.runs", runs, "must be >= 1");
  CheckOption(rounds >= 1, "BenchOptions.rounds", rounds, "must be >= 1");
  CheckOption(warmup >= 0, "BenchOptions.warmup", warmup, "must be >= 0");
  CheckOption(threads >= 0, "BenchOptions.threads", threads, "must be >= 0 (0 = all cores)");
  CheckOption(left.empty() == right.empty(), "BenchOptions.right", right.empty() ? "empty" : "set",
              "left and right must both be given or both be empty");
  if (!left.empty()) {
    CheckOption(left.size() == right.size() && left.type() == right.type(), "BenchOptions.right",
                fmt::format("{}x{}", right.cols, right.rows),
                "must have the size and type of left");
  }
}

BenchReport RunThroughputBench(const BenchOptions& options,
                               const std::function<void(const BenchRow&)>& progress) {
  options.Check();
  BenchReport report;
  report.cpu = CpuModel();
  report.hardware_threads = static_cast<int>(std::thread::hardware_concurrency());
  report.threads = options.threads > 0 ? options.threads : report.hardware_threads;
  report.simd_target = SgmSimdTarget();
  report.opencv_version = CV_VERSION;
  report.input = options.left.empty() ? "synthetic textured pair (slanted plane + box), seeded"
                                      : fmt::format("given pair ({}x{}) resized to each size",
                                                    options.left.cols, options.left.rows);
  report.runs = options.runs;
  report.warmup = options.warmup;
  report.rounds = options.rounds;
  for (const BenchSize& size : options.sizes) {
    std::vector<BenchRow> rows(options.methods.size());
    std::vector<std::vector<double>> samples(options.methods.size());
    for (size_t m = 0; m < options.methods.size(); ++m) {
      rows[m].method = options.methods[m];
      rows[m].size = size;
      if (!IsKnownMethod(options.methods[m])) {
        rows[m].skipped = true;
        rows[m].note = "not registered in the matcher factory";
      } else {
        // Settings errors (unknown key, bad value) stop the run here, not in every child.
        try {
          CreateBenchMatcher(options.methods[m], size, options.threads);
        } catch (const std::exception& e) {
          throw UsageError(fmt::format("bench method '{}': {}", options.methods[m], e.what()));
        }
      }
    }
    // Round-robin: every round measures each method once, in the same order.
    for (int round = 0; round < options.rounds; ++round) {
      for (size_t m = 0; m < options.methods.size(); ++m) {
        if (rows[m].skipped) continue;
        std::vector<double> ms;
        if (!MeasureForked(options, options.methods[m], size, &rows[m], &ms)) continue;
        samples[m].insert(samples[m].end(), ms.begin(), ms.end());
        rows[m].round_median_ms.push_back(Median(ms));
      }
    }
    for (size_t m = 0; m < rows.size(); ++m) {
      BenchRow& row = rows[m];
      if (row.skipped) continue;
      row.median_ms = Median(samples[m]);
      row.min_ms = *std::min_element(samples[m].begin(), samples[m].end());
      row.fps = 1000.0 / row.median_ms;
      row.mde_per_s = MdePerSecond(size.width, size.height, size.num_disparities, row.median_ms);
    }
    const auto base = std::find_if(rows.begin(), rows.end(), [](const BenchRow& row) {
      return row.method == "sgbm-3way" && !row.skipped;
    });
    for (BenchRow& row : rows) {
      if (base == rows.end() || row.skipped) continue;
      row.ratio_to_3way = base->median_ms / row.median_ms;  // MDE/s ratio at equal W·H·D
      std::vector<double> ratios;
      for (size_t r = 0; r < row.round_median_ms.size() && r < base->round_median_ms.size(); ++r) {
        const double ratio = base->round_median_ms[r] / row.round_median_ms[r];
        row.ratio_low = r == 0 ? ratio : std::min(row.ratio_low, ratio);
        row.ratio_high = r == 0 ? ratio : std::max(row.ratio_high, ratio);
        ratios.push_back(ratio);
      }
      if (!ratios.empty()) row.ratio_paired = Median(ratios);
    }
    for (const BenchRow& row : rows) {
      report.rows.push_back(row);
      if (progress) progress(row);
    }
  }
  return report;
}

std::string BenchMarkdown(const BenchReport& r) {
  std::ostringstream out;
  out << fmt::format(
      "machine: {} ({} hardware threads); threads used: {}; SIMD target (sgm kernels): {}; "
      "OpenCV {}\n",
      r.cpu, r.hardware_threads, r.threads, r.simd_target, r.opencv_version);
  out << fmt::format(
      "input: {}; median of {} rounds x {} runs (methods interleaved round by round, each run "
      "after {} warm-up run(s) discarded); vs SGBM_3WAY: ratio of the medians (range over the "
      "rounds); paired: median over the rounds of each round's ratio; peak = largest VmHWM of a "
      "forked child per round\n\n",
      r.input, r.rounds, r.runs, r.warmup);
  out << "| method | size | disparities | ms | fps | MDE/s | peak RSS (MiB) | added (MiB) | "
         "density % | vs SGBM_3WAY | paired |\n";
  out << "|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const BenchRow& row : r.rows) {
    const std::string size = fmt::format("{}x{}", row.size.width, row.size.height);
    if (row.skipped) {
      out << fmt::format("| {} | {} | {} | skipped: {} | | | | | | | |\n", row.method, size,
                         row.size.num_disparities, row.note);
      continue;
    }
    out << fmt::format(
        "| {} | {} | {} | {:.1f} | {:.1f} | {:.0f} | {:.0f} | {:.0f} | {:.1f} | {} | {} |\n",
        row.method, size, row.size.num_disparities, row.median_ms, row.fps, row.mde_per_s,
        row.peak_rss_mb, row.peak_added_mb, row.density,
        row.ratio_to_3way > 0 ? (row.method == "sgbm-3way" || r.rounds < 2
                                     ? fmt::format("{:.2f}x", row.ratio_to_3way)
                                     : fmt::format("{:.2f}x ({:.2f}-{:.2f})", row.ratio_to_3way,
                                                   row.ratio_low, row.ratio_high))
                              : "-",
        row.ratio_paired > 0 && row.method != "sgbm-3way" && r.rounds >= 2
            ? fmt::format("{:.2f}x", row.ratio_paired)
            : "-");
  }
  return out.str();
}

nlohmann::json BenchJson(const BenchReport& r) {
  nlohmann::json rows = nlohmann::json::array();
  for (const BenchRow& row : r.rows) {
    nlohmann::json j = {{"method", row.method},
                        {"width", row.size.width},
                        {"height", row.size.height},
                        {"num_disparities", row.size.num_disparities},
                        {"skipped", row.skipped}};
    if (row.skipped) {
      j["note"] = row.note;
    } else {
      j.update({{"median_ms", row.median_ms},
                {"min_ms", row.min_ms},
                {"fps", row.fps},
                {"mde_per_s", row.mde_per_s},
                {"peak_rss_mib", row.peak_rss_mb},
                {"peak_added_mib", row.peak_added_mb},
                {"density_percent", row.density},
                {"ratio_to_sgbm_3way", row.ratio_to_3way},
                {"ratio_to_sgbm_3way_low", row.ratio_low},
                {"ratio_to_sgbm_3way_high", row.ratio_high},
                {"ratio_to_sgbm_3way_paired", row.ratio_paired},
                {"round_median_ms", row.round_median_ms}});
    }
    rows.push_back(j);
  }
  return {{"cpu", r.cpu},
          {"hardware_threads", r.hardware_threads},
          {"threads", r.threads},
          {"simd_target", r.simd_target},
          {"opencv_version", r.opencv_version},
          {"input", r.input},
          {"runs", r.runs},
          {"warmup", r.warmup},
          {"rounds", r.rounds},
          {"rows", rows}};
}

}  // namespace linesight
