// Shared plumbing for subcommands: argument parsing with CLI11 and the mapping of errors to exit
// codes (0 success, 1 runtime error such as a bad file, 2 usage error). One line on stderr per
// error.
#pragma once

#include <functional>
#include <map>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <iostream>

#include "linesight/acquire/frame_source.h"
#include "linesight/core/atomic_file.h"
#include "linesight/io/json_io.h"
#include "linesight/ranging/pipeline.h"

namespace linesight::cli {

inline constexpr int kExitOk = 0;
inline constexpr int kExitRuntimeError = 1;
inline constexpr int kExitUsage = 2;

// Parses argv with `app`, then calls `body`. Catches CLI11 errors (exit 2, or 0 for --help),
// UsageError (2), InputError and other exceptions (1), and prints "linesight <command>: <message>"
// on stderr.
int RunCommand(CLI::App& app, int argc, char** argv, const std::function<void()>& body);

// Adds the --param key=value option (repeatable) and returns where the parsed values go.
void AddParamOption(CLI::App& app, std::vector<std::string>* raw);
// "p1=8,p2=32" / ["p1=8","p2=32"] -> {p1: 8, p2: 32} (ParseKeyValues); throws UsageError for an
// entry without '='.
std::map<std::string, std::string> ParseParams(const std::vector<std::string>& raw);

// Adds the --ranging key=value option (repeatable) of the ranging chain's settings (range, eval
// ranging, eval plates), and their table (RangingSettingsTable) to the help's footer. The values
// go to linesight::ApplyRangingSettings("--ranging", raw, &options).
void AddRangingSettingsOption(CLI::App& app, std::vector<std::string>* raw);

// Adds the line-geometry options of the synthetic power-line scene (--conductor-offset-x,
// --conductor-offset-y, --conductor-yaw, --tower-offset-x) of `render` and `eval ranging`.
void AddLineGeometryOptions(CLI::App& app, double* conductor_offset_x_m,
                            double* conductor_offset_y_m, double* conductor_yaw_rad,
                            double* tower_offset_x_m);

// Adds --source and the capture options (--width --height --fps --loop --synthetic-*) of
// `serve` and `acquire`.
void AddSourceOptions(CLI::App& app, std::string* spec, FrameSourceOptions* options);

// Where a command prints its human-readable table: stdout, or stderr when the JSON report goes to
// stdout (`--json -`), so that stdout then holds one JSON document.
inline std::ostream& TableStream(const std::string& json_path) {
  return json_path == "-" ? std::cerr : std::cout;
}

// Shows a study's report: markdown on stdout (unless the JSON goes to stdout), and the markdown,
// JSON and plot files that were asked for. Report needs ToMarkdown(), ToJson() and WritePlots(dir).
template <typename Report>
void EmitReport(const Report& report, const std::string& json_path,
                const std::string& markdown_path, const std::string& plots_dir) {
  const std::string markdown = report.ToMarkdown();
  if (json_path != "-") std::cout << markdown << std::flush;
  if (!markdown_path.empty()) WriteTextAtomic(markdown_path, markdown);
  if (!json_path.empty()) WriteJson(json_path, report.ToJson());
  if (!plots_dir.empty()) report.WritePlots(plots_dir);
}

}  // namespace linesight::cli
