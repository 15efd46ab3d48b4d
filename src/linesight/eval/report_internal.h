// Internal to `linesight eval report` (report.h): the study runs (report_runs.cc) and the sections
// of the page (report_sections.cc) that GenerateReport (report.cc) puts together.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "linesight/core/progress.h"
#include "linesight/eval/dataset.h"
#include "linesight/eval/eval_stereo.h"
#include "linesight/eval/noise.h"
#include "linesight/eval/obstacle_images.h"
#include "linesight/eval/report.h"
#include "linesight/eval/result_cache.h"
#include "linesight/eval/sweep.h"

namespace linesight::detail {

// ---------------------------------------------------------------------------------------------
// Runs (report_runs.cc)

// Whether `set` is one of `sets` ("*" = every set).
bool InSets(const std::vector<std::string>& sets, const std::string& set);

// The scenes of `scenes` in `sets` (InSets); every scene when `sets` is empty.
std::vector<SceneRef> FilterScenes(const std::vector<SceneRef>& scenes,
                                   const std::vector<std::string>& sets);

// "set/scene" of a result.
inline std::string SceneKey(const EvalStereoResult& r) { return r.set + "/" + r.scene; }

// A progress bar on stderr, drawn when options.show_progress and stderr is a terminal.
std::unique_ptr<ProgressBar> MakeProgress(const ReportOptions& options, int64_t total,
                                          const std::string& label);

// Number of gc runs side by side (ReportOptions::gc_jobs, 0 = one per hardware thread).
int GcJobs(const ReportOptions& options);

// Runs `methods` on `scenes` at `noise`; gc only on the scenes of `gc_sets` and after the other
// methods (RunGcJobs). Results sorted by scene order, noise order, method order.
std::vector<EvalStereoResult> RunStudy(const std::vector<SceneRef>& scenes,
                                       const std::vector<std::string>& methods,
                                       const std::vector<NoiseSpec>& noise,
                                       const std::vector<std::string>& gc_sets,
                                       const ReportOptions& options, const ResultCache* cache,
                                       const std::string& label, std::vector<std::string>* missing);

// ---------------------------------------------------------------------------------------------
// Sections of the page (report_sections.cc)

struct Provenance {
  std::string command, data, machine, commit, date;
  std::string Caption(const std::string& what) const {
    return fmt::format("*{} — produced by `{}` on data `{}`, machine: {}, commit {}, {}.*\n\n",
                       what, command, data, machine, commit, date);
  }
};

// Section 1: correct-match rate and total time per method on the paper's set.
std::string ComparisonSection(const std::vector<EvalStereoResult>& bench,
                              const std::vector<std::string>& methods, const Provenance& prov);

// Section 3: headline error per method and noise setting (tables, per-scene details, plot
// noise.svg in out_dir).
std::string NoiseSection(const std::vector<EvalStereoResult>& noisy,
                         const std::vector<std::string>& methods,
                         const std::vector<NoiseSpec>& noise, const std::filesystem::path& out_dir,
                         const Provenance& prov, const std::string& gc_note);

// Section 6: where isgm beats or loses to each other method, computed from the numbers.
std::string ConclusionSection(const std::vector<EvalStereoResult>& bench,
                              const std::vector<EvalStereoResult>& noisy,
                              const std::vector<std::string>& noise_labels,
                              const std::vector<std::string>& methods, const SweepReport* sweep,
                              const EvalObstaclesReport* obstacles);

// Section 7: every row taken from the result cache, with the run that measured it, and the cells
// that are missing.
std::string CacheSection(const std::vector<EvalStereoResult>& bench,
                         const std::vector<EvalStereoResult>& noisy,
                         const std::vector<std::string>& missing);

}  // namespace linesight::detail
