#include "linesight/eval/sweep.h"

#include <algorithm>
#include <limits>
#include <set>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "linesight/core/atomic_file.h"
#include "linesight/core/error.h"
#include "linesight/core/progress.h"
#include "linesight/core/timer.h"
#include "linesight/eval/eval_stereo.h"
#include "linesight/eval/metrics.h"
#include "linesight/eval/plot.h"
#include "linesight/stereo/isgm.h"
#include "linesight/stereo/matcher.h"

namespace linesight {
namespace fs = std::filesystem;

namespace {

std::vector<std::string> Range(int first, int last, int step) {
  std::vector<std::string> out;
  for (int v = first; v <= last; v += step) out.push_back(std::to_string(v));
  return out;
}

const std::vector<std::string> kNumDisparities = Range(16, 112, 16);

// `p` with `centre` (formatted as fmt does: 14, 0.5) as its centre, inserted among the swept
// values in numeric order when it is not one of them.
SweepParameter WithCentre(SweepParameter p, double centre) {
  p.centre = fmt::format("{}", centre);
  if (std::find(p.values.begin(), p.values.end(), p.centre) == p.values.end()) {
    const auto at = std::find_if(p.values.begin(), p.values.end(),
                                 [&](const std::string& v) { return std::stod(v) > centre; });
    p.values.insert(at, p.centre);
  }
  return p;
}

// The plane-fit inlier thresholds swept for isgm: those not above the outlier threshold (the
// refinement requires inlier <= outlier, and varying both would not be one parameter at a time).
std::vector<std::string> InlierValuesUpTo(double outlier_threshold) {
  std::vector<std::string> out;
  for (const char* v : {"0.25", "0.35", "0.5", "0.75", "1", "1.5", "2"}) {
    if (std::stod(v) <= outlier_threshold) out.push_back(v);
  }
  return out;
}

}  // namespace

std::vector<SweepParameter> DefaultSweepParameters(const std::string& method) {
  const SweepParameter num_disp{method, kSweepNumDisparitiesKey, kNumDisparities, "64"};
  if (method == "sgbm" || method == "sgbm-wls") {
    return {num_disp,
            {method, "block", Range(3, 11, 2), "7"},
            {method, "uniqueness", Range(5, 15, 1), "10"}};
  }
  if (method == "bm") {
    // StereoBM needs block >= 5.
    return {num_disp,
            {method, "block", Range(5, 11, 2), "7"},
            {method, "uniqueness", Range(5, 15, 1), "10"}};
  }
  if (method == "isgm") {
    // Centre = isgm's own defaults, taken from the matcher so that the sweep follows them.
    const SgmOptions sgm = IsgmDefaultSgmOptions();
    const PlaneRefinementOptions refine = IsgmDefaultRefinementOptions();
    return {num_disp, WithCentre({method, "p1", {"4", "8", "14", "20", "28", "40"}, ""}, sgm.p1),
            WithCentre({method, "p2", {"60", "80", "100", "130", "160", "190", "250"}, ""}, sgm.p2),
            WithCentre({method, "superpixel_size", {"6", "8", "10", "12", "16", "20", "24"}, ""},
                       refine.superpixels.region_size),
            WithCentre({method, "plane_inlier", InlierValuesUpTo(refine.outlier_threshold), ""},
                       refine.inlier_threshold)};
  }
  if (method == "sgm") {
    return {num_disp,
            {method, "p1", {"8", "14", "20", "28", "40"}, "28"},
            {method, "p2", {"60", "80", "100", "130", "160", "190"}, "100"}};
  }
  if (method == "gc") return {num_disp};
  return {};
}

std::vector<std::string> MethodsWithDefaultSweep() {
  std::vector<std::string> methods;
  for (const std::string& method : MatcherNames()) {
    if (!DefaultSweepParameters(method).empty()) methods.push_back(method);
  }
  return methods;
}

void SweepOptions::Check() const {
  CheckOption(!methods.empty() || !parameters.empty(), "SweepOptions.methods", "(empty)",
              "name at least one method");
  CheckOption(threads >= 0, "SweepOptions.threads", threads, "must be >= 0");
  for (const SweepParameter& p : parameters) {
    CheckOption(!p.values.empty(), "SweepOptions.parameters.values", p.method + "." + p.key,
                "needs at least one value");
    CheckOption(std::find(p.values.begin(), p.values.end(), p.centre) != p.values.end(),
                "SweepOptions.parameters.centre", p.method + "." + p.key + "=" + p.centre,
                "must be one of the swept values");
  }
}

namespace {

std::vector<SweepParameter> EffectiveParameters(const SweepOptions& options) {
  if (!options.parameters.empty()) return options.parameters;
  std::vector<SweepParameter> out;
  for (const std::string& method : options.methods) {
    const auto params = DefaultSweepParameters(method);
    if (params.empty()) {
      throw UsageError(fmt::format("no parameter study is defined for method '{}' ({} have one)",
                                   method, fmt::join(MethodsWithDefaultSweep(), ", ")));
    }
    out.insert(out.end(), params.begin(), params.end());
  }
  return out;
}

// The centre point of `method`: every parameter at its centre.
std::map<std::string, std::string> CentreOf(const std::vector<SweepParameter>& params,
                                            const std::string& method) {
  std::map<std::string, std::string> centre;
  for (const SweepParameter& p : params) {
    if (p.method == method) centre[p.key] = p.centre;
  }
  if (!centre.count(kSweepNumDisparitiesKey)) centre[kSweepNumDisparitiesKey] = "";
  return centre;
}

struct SceneScore {
  std::string set;
  double rmse = 0, bad = 0, bad1 = 0, density = 0, ms = 0;
  std::string label;
};

std::string SettingsKey(const std::string& method, const std::map<std::string, std::string>& s) {
  std::string key = method;
  for (const auto& [k, v] : s) key += ";" + k + "=" + v;
  return key;
}

}  // namespace

int64_t SweepSteps(const SweepOptions& options, size_t num_scenes) {
  int64_t points = 0;
  for (const SweepParameter& p : EffectiveParameters(options)) {
    points += static_cast<int64_t>(p.values.size());
  }
  return points * static_cast<int64_t>(num_scenes);
}

SweepReport RunSweep(const std::vector<SceneRef>& scenes, const SweepOptions& options,
                     ProgressBar* progress) {
  options.Check();
  const std::vector<SweepParameter> params = EffectiveParameters(options);
  if (scenes.empty()) throw InputError("parameter study: no scenes to evaluate");

  // Build every setting first so that unknown methods and keys fail before any work.
  struct Job {
    size_t curve;
    std::string value;
    std::map<std::string, std::string> settings;
  };
  SweepReport report;
  std::vector<Job> jobs;
  for (const SweepParameter& p : params) {
    SweepCurve curve;
    curve.method = p.method;
    curve.key = p.key;
    curve.centre = p.centre;
    const auto centre = CentreOf(params, p.method);
    for (const auto& [k, v] : centre) {
      if (k != p.key && !v.empty()) curve.fixed[k] = v;
    }
    for (const std::string& value : p.values) {
      auto settings = centre;
      settings[p.key] = value;
      jobs.push_back({report.curves.size(), value, settings});
    }
    report.curves.push_back(curve);
  }
  auto matcher_options = [&](const std::map<std::string, std::string>& settings,
                             const StereoScene* scene) {
    MatcherOptions m;
    m.threads = options.threads;
    if (scene) {
      m.min_disparity = scene->min_disparity;
      m.num_disparities = scene->num_disparities;
    }
    for (const auto& [k, v] : settings) {
      if (k == kSweepNumDisparitiesKey) {
        if (!v.empty()) {
          try {
            m.num_disparities = std::stoi(v);
          } catch (const std::exception&) {
            throw UsageError(fmt::format("num_disp value '{}' is not an integer", v));
          }
        }
      } else {
        m.params[k] = v;
      }
    }
    return m;
  };
  for (const Job& job : jobs) {
    CreateMatcher(report.curves[job.curve].method, matcher_options(job.settings, nullptr));
  }

  std::map<std::string, std::vector<SceneScore>> cache;  // SettingsKey -> per scene
  std::vector<std::vector<SceneScore>> job_scores(jobs.size());
  std::set<std::string> labels;
  for (const SceneRef& ref : scenes) {
    const StereoScene scene = LoadScene(ref);
    report.scene_names.push_back(ref.set + "/" + ref.name);
    for (size_t j = 0; j < jobs.size(); ++j) {
      const Job& job = jobs[j];
      const std::string& method = report.curves[job.curve].method;
      const std::string key = SettingsKey(method, job.settings) + "@" + ref.set + "/" + ref.name;
      auto it = cache.find(key);
      if (it == cache.end()) {
        auto matcher = CreateMatcher(method, matcher_options(job.settings, &scene));
        Stopwatch watch;
        const cv::Mat disparity = matcher->Compute(scene.left, scene.right).disparity;
        const double ms = watch.ElapsedMs();
        EvalStereoResult result;
        result.set = ref.set;
        result.regions = ComputeRegionMetrics(disparity, scene.ground_truth, scene.masks);
        const PrimaryMetric primary = PrimaryMetricFor(result);
        const DisparityMetrics& m = result.regions.at(primary.region);
        SceneScore score{ref.set, m.rmse, primary.value, m.bad[1], m.density, ms, primary.label};
        it = cache.emplace(key, std::vector<SceneScore>{score}).first;
      }
      job_scores[j].push_back(it->second.front());
      labels.insert(it->second.front().label);
      if (progress) {
        progress->Advance(1, fmt::format("{}/{} {} {}={}", ref.set, ref.name, method,
                                         report.curves[job.curve].key, job.value));
      }
    }
  }
  report.bad_label = labels.size() == 1 ? *labels.begin() : "headline bad";

  for (size_t j = 0; j < jobs.size(); ++j) {
    // Mean per set, then over sets.
    std::map<std::string, std::pair<SceneScore, int>> per_set;
    for (const SceneScore& s : job_scores[j]) {
      auto& [acc, n] = per_set[s.set];
      acc.rmse += s.rmse;
      acc.bad += s.bad;
      acc.bad1 += s.bad1;
      acc.density += s.density;
      acc.ms += s.ms;
      ++n;
    }
    SweepPoint point;
    point.value = jobs[j].value;
    point.scenes = static_cast<int>(job_scores[j].size());
    for (const auto& [set, acc] : per_set) {
      const double n = acc.second;
      point.rmse += acc.first.rmse / n;
      point.bad += acc.first.bad / n;
      point.bad1 += acc.first.bad1 / n;
      point.density += acc.first.density / n;
      point.ms += acc.first.ms / n;
    }
    const double sets = static_cast<double>(per_set.size());
    point.rmse /= sets;
    point.bad /= sets;
    point.bad1 /= sets;
    point.density /= sets;
    point.ms /= sets;
    report.curves[jobs[j].curve].points.push_back(point);
  }
  return report;
}

nlohmann::json SweepReport::ToJson() const {
  nlohmann::json curves_json = nlohmann::json::array();
  for (const SweepCurve& c : curves) {
    nlohmann::json points = nlohmann::json::array();
    for (const SweepPoint& p : c.points) {
      points.push_back({{"value", p.value},
                        {"rmse", p.rmse},
                        {"bad", p.bad},
                        {"bad_1", p.bad1},
                        {"density", p.density},
                        {"ms", p.ms},
                        {"scenes", p.scenes}});
    }
    curves_json.push_back({{"method", c.method},
                           {"parameter", c.key},
                           {"centre", c.centre},
                           {"fixed", c.fixed},
                           {"points", points}});
  }
  return {{"scenes", scene_names}, {"bad_label", bad_label}, {"curves", curves_json}};
}

namespace {

std::vector<std::string> KeysInOrder(const std::vector<SweepCurve>& curves) {
  std::vector<std::string> keys;
  for (const SweepCurve& c : curves) {
    if (std::find(keys.begin(), keys.end(), c.key) == keys.end()) keys.push_back(c.key);
  }
  return keys;
}

std::string KeyTitle(const std::string& key) {
  if (key == kSweepNumDisparitiesKey) return "num-disp (px searched)";
  return key;
}

}  // namespace

std::string SweepReport::ToMarkdown() const {
  std::string out;
  out += fmt::format(
      "One parameter at a time around the centre point; every other parameter stays at its centre "
      "value. Averaged over {} scene(s) ({}), per set first. RMSE (px) over estimated pixels of "
      "the "
      "headline region, {} dense (a pixel without an estimate counts as bad), density %. The "
      "num-disp sweep replaces each scene's own search range, so scenes whose ground truth "
      "exceeds the searched range get worse at small num-disp. SGBM and BM also leave the first "
      "num-disp columns of the image without an estimate, so a larger num-disp lowers their "
      "density.\n\n",
      scene_names.size(), fmt::join(scene_names, ", "), bad_label);
  for (const std::string& key : KeysInOrder(curves)) {
    std::vector<const SweepCurve*> group;
    for (const SweepCurve& c : curves) {
      if (c.key == key) group.push_back(&c);
    }
    out += fmt::format("#### {}\n\n", KeyTitle(key));
    for (const SweepCurve* c : group) {
      std::string fixed;
      for (const auto& [k, v] : c->fixed)
        fixed += fmt::format("{}{}={}", fixed.empty() ? "" : ", ", k, v);
      out += fmt::format("- {}: centre {}{}\n", c->method, c->centre,
                         fixed.empty() ? "" : "; others fixed at " + fixed);
    }
    // Union of values in order of appearance.
    std::vector<std::string> values;
    for (const SweepCurve* c : group) {
      for (const SweepPoint& p : c->points) {
        if (std::find(values.begin(), values.end(), p.value) == values.end()) {
          values.push_back(p.value);
        }
      }
    }
    if (key != "block" && key != kSweepNumDisparitiesKey && key != "uniqueness") {
      // Numeric order for mixed value lists.
      std::stable_sort(
          values.begin(), values.end(),
          [](const std::string& a, const std::string& b) { return std::stod(a) < std::stod(b); });
    }
    out += "\n| " + key + " |";
    std::string rule = "|---|";
    for (const SweepCurve* c : group) {
      out += fmt::format(" {} RMSE | {} {} | {} density |", c->method, c->method, bad_label,
                         c->method);
      rule += "---|---|---|";
    }
    out += "\n" + rule + "\n";
    for (const std::string& value : values) {
      out += "| " + value + " |";
      for (const SweepCurve* c : group) {
        const auto it = std::find_if(c->points.begin(), c->points.end(),
                                     [&](const SweepPoint& p) { return p.value == value; });
        if (it == c->points.end()) {
          out += " – | – | – |";
        } else {
          const bool centre = value == c->centre;
          out += fmt::format(" {}{:.2f}{} | {}{:.2f}{} | {:.1f} |", centre ? "**" : "", it->rmse,
                             centre ? "**" : "", centre ? "**" : "", it->bad, centre ? "**" : "",
                             it->density);
        }
      }
      out += "\n";
    }
    out += "\n";
  }
  return out;
}

std::vector<std::string> SweepReport::WritePlots(const fs::path& dir) const {
  fs::create_directories(dir);
  const auto keys = KeysInOrder(curves);
  std::vector<std::string> written;
  for (const bool rmse : {true, false}) {
    std::vector<LineChart> panels;
    for (const std::string& key : keys) {
      LineChart chart;
      chart.title = KeyTitle(key);
      chart.x_label = key;
      chart.y_label = rmse ? "RMSE (px)" : bad_label + " (%)";
      std::vector<double> xs;
      for (const SweepCurve& c : curves) {
        if (c.key != key) continue;
        for (const SweepPoint& p : c.points) {
          const double x = std::stod(p.value);
          if (std::find(xs.begin(), xs.end(), x) == xs.end()) xs.push_back(x);
        }
      }
      std::sort(xs.begin(), xs.end());
      for (const double x : xs) chart.x_ticks.push_back(fmt::format("{:g}", x));
      for (const SweepCurve& c : curves) {
        if (c.key != key) continue;
        PlotSeries series{c.method,
                          std::vector<double>(xs.size(), std::numeric_limits<double>::quiet_NaN())};
        for (const SweepPoint& p : c.points) {
          const size_t i = std::find(xs.begin(), xs.end(), std::stod(p.value)) - xs.begin();
          series.y[i] = rmse ? p.rmse : p.bad;
        }
        chart.series.push_back(series);
      }
      panels.push_back(chart);
    }
    const std::string name = rmse ? "sweep_rmse.svg" : "sweep_bad.svg";
    WriteSvgPanels(dir / name, panels, std::min<int>(3, static_cast<int>(panels.size())));
    written.push_back(name);
  }
  return written;
}

}  // namespace linesight
