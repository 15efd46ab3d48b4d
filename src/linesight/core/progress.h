// A progress bar for long-running commands. It draws on stderr only when stderr is a terminal
// (so logs and CI output stay clean) and is safe to advance from several threads.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <mutex>
#include <string>

namespace linesight {

class ProgressBar {
 public:
  // `total` steps; `label` is shown before the bar. `enabled` defaults to "stderr is a terminal".
  ProgressBar(int64_t total, std::string label);
  ProgressBar(int64_t total, std::string label, bool enabled);
  ~ProgressBar();
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;

  // Advances by `n` steps and sets the text shown after the bar (e.g. the current item).
  void Advance(int64_t n = 1, const std::string& detail = "");
  // Completes the bar and ends the line.
  void Finish();

  int64_t done() const { return done_.load(); }
  bool enabled() const { return enabled_; }

  // Renders the bar line for `done` of `total` (exposed for tests).
  static std::string Render(const std::string& label, int64_t done, int64_t total, double elapsed_s,
                            const std::string& detail, int width = 30);

 private:
  void Draw(const std::string& detail);

  const int64_t total_;
  const std::string label_;
  const bool enabled_;
  std::atomic<int64_t> done_{0};
  bool finished_ = false;
  std::mutex mutex_;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_draw_;
};

// True when stderr is an interactive terminal.
bool StderrIsTerminal();

}  // namespace linesight
