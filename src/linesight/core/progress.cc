#include "linesight/core/progress.h"

#include <unistd.h>

#include <algorithm>
#include <cstdio>

#include <fmt/format.h>

namespace linesight {

bool StderrIsTerminal() { return ::isatty(STDERR_FILENO) == 1; }

ProgressBar::ProgressBar(int64_t total, std::string label)
    : ProgressBar(total, std::move(label), StderrIsTerminal()) {}

ProgressBar::ProgressBar(int64_t total, std::string label, bool enabled)
    : total_(std::max<int64_t>(total, 1)),
      label_(std::move(label)),
      enabled_(enabled),
      start_(std::chrono::steady_clock::now()),
      last_draw_(start_) {
  if (enabled_) Draw("");
}

ProgressBar::~ProgressBar() { Finish(); }

std::string ProgressBar::Render(const std::string& label, int64_t done, int64_t total,
                                double elapsed_s, const std::string& detail, int width) {
  total = std::max<int64_t>(total, 1);
  done = std::clamp<int64_t>(done, 0, total);
  const int filled = static_cast<int>(width * done / total);
  std::string bar(static_cast<size_t>(filled), '#');
  bar.append(static_cast<size_t>(width - filled), '.');
  std::string eta;
  if (done > 0 && done < total) {
    eta = fmt::format(" eta {:.0f}s", elapsed_s * static_cast<double>(total - done) / done);
  }
  return fmt::format("{} [{}] {}/{} {:.1f}s{}{}{}", label, bar, done, total, elapsed_s, eta,
                     detail.empty() ? "" : "  ", detail);
}

void ProgressBar::Advance(int64_t n, const std::string& detail) {
  done_.fetch_add(n);
  if (!enabled_) return;
  std::lock_guard<std::mutex> lock(mutex_);
  const auto now = std::chrono::steady_clock::now();
  if (done_.load() < total_ && now - last_draw_ < std::chrono::milliseconds(100)) return;
  last_draw_ = now;
  Draw(detail);
}

void ProgressBar::Draw(const std::string& detail) {
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  const std::string line = Render(label_, done_.load(), total_, elapsed, detail);
  std::fprintf(stderr, "\r\033[K%s", line.c_str());
  std::fflush(stderr);
}

void ProgressBar::Finish() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (finished_) return;
  finished_ = true;
  if (!enabled_) return;
  done_.store(total_);
  Draw("");
  std::fprintf(stderr, "\n");
  std::fflush(stderr);
}

}  // namespace linesight
