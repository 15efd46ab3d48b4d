// `linesight eval report`: regenerates one markdown page (docs/results/README.md) with every table
// and plot of the comparison study:
//   1. a paper-style comparison table (correct-match rate = 100 - headline bad % per scene, total
//      operation time) per method;
//   2. the stereo benchmark tables (every method over every set, clean);
//   3. noise robustness (clean, gauss:0.1, gauss:0.2, sp:0.15, sp:0.35): table + plot;
//   4. the parameter study (RunSweep): table per parameter + plots;
//   5. the obstacle images (RunEvalObstacles): table + plot;
//   6. a conclusion computed from the numbers (where isgm beats or loses to each baseline on
//      accuracy, noise robustness and time).
// Every figure names the command, data, machine (CPU model, cores), git commit and date that
// produced it. gc (graph cuts) takes seconds to minutes per scene and is single-threaded: its runs
// (one per scene and noise setting) go side by side on `gc_jobs` threads after the other methods.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "linesight/eval/noise.h"
#include "linesight/eval/obstacle_images.h"

namespace linesight {

struct ReportOptions {
  std::filesystem::path data_dir;  // benchmark scenes (FindScenes)
  std::filesystem::path out_dir;   // README.md and the SVG plots go here
  // Methods in table order; "isgm" is the method the conclusion compares with the others.
  std::vector<std::string> methods = {"isgm", "sgm", "sgbm", "sgbm-wls", "bm", "gc"};
  // Sets the benchmark tables cover; empty = every set found.
  std::vector<std::string> sets;
  // Sets gc runs on (benchmark and noise); "*" = every set.
  std::vector<std::string> gc_sets = {"*"};
  // Sets on which gc also runs the noise settings (within gc_sets); "*" = every set. Under strong
  // noise a gc run takes 4-8 times its clean time (about 2.5 CPU hours for every shared set).
  std::vector<std::string> gc_noise_sets = {"*"};
  // gc runs executed side by side (each single-threaded); 0 = one per hardware thread. Results do
  // not depend on it; gc's times do (the page states the value).
  int gc_jobs = 0;
  // Noise study: settings (clean first) and the sets it covers (empty = every benchmark set).
  std::vector<NoiseSpec> noise = {NoiseSpec::Parse("clean"), NoiseSpec::Parse("gauss:0.1"),
                                  NoiseSpec::Parse("gauss:0.2"), NoiseSpec::Parse("sp:0.15"),
                                  NoiseSpec::Parse("sp:0.35")};
  std::vector<std::string> noise_sets;
  // Parameter study: methods and sets (empty sets = the first benchmark set); at most
  // `sweep_max_scenes` scenes (0 = all).
  std::vector<std::string> sweep_methods = {"sgbm", "sgbm-wls", "isgm"};
  // Empty sweep_sets = middlebury-2001-2003 when present, else the first benchmark set.
  std::vector<std::string> sweep_sets;
  int sweep_max_scenes = 0;
  // Obstacle images (rendered power-line scene); methods = `methods`.
  bool obstacles = true;
  ObstacleImageOptions obstacle_images;
  uint64_t noise_seed = 1;
  int threads = 0;  // matcher threads, 0 = all cores
  // Result cache (result_cache.h), e.g. /work/cache/eval; empty = none. Every benchmark and noise
  // result computed is stored there; the methods in `cache_read_methods` ("*" = all) take theirs
  // from it on an exact key match. The default reads only gc (hours), so the other methods' times
  // come from this run. The page lists every cached row with the commit, machine and date that
  // measured it.
  std::filesystem::path cache_dir;
  std::vector<std::string> cache_read_methods = {"gc"};
  // gc only from the cache: a gc cell without an entry is not run; the page lists it as missing.
  bool gc_cached_only = false;
  // Provenance printed with every figure.
  std::string command_line = "linesight eval report";
  std::string commit = "unknown";  // git commit of the sources (GitDescription)
  bool show_progress = true;       // progress bars on stderr (only drawn on a terminal)

  void Check() const;
  // Smaller settings for `--quick`: benchmark and noise only on middlebury-2001-2003 (which must
  // exist), parameter study on two of its scenes, obstacle images with supersampling 2.
  void MakeQuick();
};

// "<CPU model> (<n> hardware threads)" from /proc/cpuinfo and std::thread.
std::string MachineDescription();

// `git describe --always --dirty --abbrev=12` of the work tree holding `dir` plus the commit date,
// e.g. "44c1197a3f2e (2026-11-22 03:05 UTC)"; "unknown" when git or the repository is missing.
std::string GitDescription(const std::filesystem::path& dir);

// Runs every study and writes <out_dir>/README.md (atomically) plus its SVG plots; returns the
// page. Throws InputError when data_dir holds no scenes of the requested sets or a named set
// (sets, gc_sets, noise_sets, sweep_sets) does not exist, UsageError for an unknown method; both
// before anything is written.
std::string GenerateReport(const ReportOptions& options);

}  // namespace linesight
