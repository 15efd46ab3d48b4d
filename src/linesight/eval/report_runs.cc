// The study runs of `linesight eval report` (report_internal.h): every method but gc through
// RunEvalStereo, then gc's single-threaded runs side by side.
#include <algorithm>
#include <atomic>
#include <exception>
#include <memory>
#include <thread>
#include <tuple>
#include <vector>

#include "linesight/core/progress.h"
#include "linesight/core/scoped_threads.h"
#include "linesight/eval/eval_stereo.h"
#include "linesight/eval/report_internal.h"

namespace linesight::detail {

bool InSets(const std::vector<std::string>& sets, const std::string& set) {
  return std::find(sets.begin(), sets.end(), "*") != sets.end() ||
         std::find(sets.begin(), sets.end(), set) != sets.end();
}

std::vector<SceneRef> FilterScenes(const std::vector<SceneRef>& scenes,
                                   const std::vector<std::string>& sets) {
  if (sets.empty()) return scenes;
  std::vector<SceneRef> out;
  for (const SceneRef& s : scenes) {
    if (InSets(sets, s.set)) out.push_back(s);
  }
  return out;
}

std::unique_ptr<ProgressBar> MakeProgress(const ReportOptions& options, int64_t total,
                                          const std::string& label) {
  return std::make_unique<ProgressBar>(total, label, options.show_progress && StderrIsTerminal());
}

int GcJobs(const ReportOptions& options) { return ResolveThreadCount(options.gc_jobs); }

namespace {

// gc on every (scene, noise) pair, single-threaded runs side by side on GcJobs() threads. Every
// run is independent (own matcher, noise seeded per scene and view), so the results do not depend
// on the number of jobs; the first error is rethrown after all threads have stopped.
// Cache-only mode (options.gc_cached_only): cells without an entry go to `missing`.
std::vector<EvalStereoResult> RunGcJobs(const std::vector<SceneRef>& scenes,
                                        const std::vector<NoiseSpec>& noise,
                                        const ReportOptions& options, const ResultCache* cache,
                                        ProgressBar* progress, std::vector<std::string>* missing) {
  const size_t count = scenes.size() * noise.size();
  std::vector<EvalStereoReport> slots(count);
  std::vector<std::exception_ptr> errors(count);
  std::atomic<size_t> next{0};
  std::atomic<bool> failed{false};
  auto worker = [&] {
    for (size_t job = next++; job < count && !failed; job = next++) {
      try {
        EvalStereoOptions eval;
        eval.methods = {"gc"};
        eval.noise = {noise[job % noise.size()]};
        eval.noise_seed = options.noise_seed;
        eval.threads = 1;
        eval.cache = cache;
        eval.cache_read_methods = options.cache_read_methods;
        if (options.gc_cached_only) eval.cache_only_methods = {"gc"};
        slots[job] = RunEvalStereo({scenes[job / noise.size()]}, eval, progress);
      } catch (...) {
        errors[job] = std::current_exception();
        failed = true;
      }
    }
  };
  const int jobs = std::min<int>(GcJobs(options), static_cast<int>(count));
  std::vector<std::thread> threads;
  for (int i = 1; i < jobs; ++i) threads.emplace_back(worker);
  worker();
  for (std::thread& t : threads) t.join();
  for (const std::exception_ptr& e : errors) {
    if (e) std::rethrow_exception(e);
  }
  std::vector<EvalStereoResult> results;
  for (auto& slot : slots) {
    results.insert(results.end(), slot.results.begin(), slot.results.end());
    missing->insert(missing->end(), slot.missing.begin(), slot.missing.end());
  }
  return results;
}

}  // namespace

// Runs `methods` on `scenes` at `noise`; gc only on the scenes of `gc_sets` and after the other
// methods (RunGcJobs). Results sorted by scene order, noise order, method order.
std::vector<EvalStereoResult> RunStudy(const std::vector<SceneRef>& scenes,
                                       const std::vector<std::string>& methods,
                                       const std::vector<NoiseSpec>& noise,
                                       const std::vector<std::string>& gc_sets,
                                       const ReportOptions& options, const ResultCache* cache,
                                       const std::string& label,
                                       std::vector<std::string>* missing) {
  std::vector<std::string> fast;
  bool gc = false;
  for (const std::string& m : methods) {
    if (m == "gc") {
      gc = true;
    } else {
      fast.push_back(m);
    }
  }
  const std::vector<SceneRef> gc_scenes =
      gc && !gc_sets.empty() ? FilterScenes(scenes, gc_sets) : std::vector<SceneRef>();
  const int64_t total = static_cast<int64_t>(noise.size()) *
                        static_cast<int64_t>(scenes.size() * fast.size() + gc_scenes.size());
  auto progress = MakeProgress(options, total, label);
  std::vector<EvalStereoResult> results;
  if (!fast.empty() && !scenes.empty()) {
    EvalStereoOptions eval;
    eval.noise = noise;
    eval.noise_seed = options.noise_seed;
    eval.threads = options.threads;
    eval.methods = fast;
    eval.cache = cache;
    eval.cache_read_methods = options.cache_read_methods;
    auto r = RunEvalStereo(scenes, eval, progress.get()).results;
    results.insert(results.end(), r.begin(), r.end());
  }
  if (!gc_scenes.empty()) {
    auto r = RunGcJobs(gc_scenes, noise, options, cache, progress.get(), missing);
    results.insert(results.end(), r.begin(), r.end());
  }
  progress->Finish();
  auto index = [](const auto& list, const std::string& key) {
    return std::find(list.begin(), list.end(), key) - list.begin();
  };
  std::vector<std::string> scene_order, noise_order;
  for (const SceneRef& s : scenes) scene_order.push_back(s.set + "/" + s.name);
  for (const NoiseSpec& n : noise) noise_order.push_back(n.Label());
  std::stable_sort(results.begin(), results.end(),
                   [&](const EvalStereoResult& a, const EvalStereoResult& b) {
                     return std::make_tuple(index(scene_order, SceneKey(a)),
                                            index(noise_order, a.noise), index(methods, a.method)) <
                            std::make_tuple(index(scene_order, SceneKey(b)),
                                            index(noise_order, b.noise), index(methods, b.method));
                   });
  return results;
}

// Mean headline figure (dense %) of `method` at `noise`, per set first and then over sets, over

}  // namespace linesight::detail
