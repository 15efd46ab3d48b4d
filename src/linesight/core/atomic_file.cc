#include "linesight/core/atomic_file.h"

#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <system_error>

#include <fmt/format.h>

#include "linesight/core/error.h"

namespace linesight {
namespace fs = std::filesystem;

namespace {
fs::path TempPathFor(const fs::path& path) {
  static std::atomic<unsigned> counter{0};
  const fs::path parent = path.parent_path();
  const std::string name = fmt::format(".{}.tmp{}-{}{}", path.stem().string(), ::getpid(),
                                       counter.fetch_add(1), path.extension().string());
  return parent.empty() ? fs::path(name) : parent / name;
}
}  // namespace

void WriteFileAtomic(const fs::path& path, const std::function<void(const fs::path&)>& write) {
  const fs::path parent = path.parent_path();
  if (!parent.empty() && !fs::is_directory(parent)) {
    throw InputError(fmt::format("{}: cannot write: folder '{}' does not exist", path.string(),
                                 parent.string()));
  }
  const fs::path tmp = TempPathFor(path);
  try {
    write(tmp);
  } catch (...) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw;
  }
  std::error_code ec;
  if (!fs::exists(tmp, ec)) {
    throw InputError(fmt::format("{}: cannot write: the writer produced no file", path.string()));
  }
  fs::rename(tmp, path, ec);
  if (ec) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw InputError(fmt::format("{}: cannot write: {}", path.string(), ec.message()));
  }
}

void WriteTextAtomic(const fs::path& path, std::string_view content) {
  if (path == "-") {
    std::fwrite(content.data(), 1, content.size(), stdout);
    std::fflush(stdout);
    return;
  }
  WriteFileAtomic(path, [&](const fs::path& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    if (!out) throw InputError(fmt::format("{}: cannot open for writing", path.string()));
    out.write(content.data(), static_cast<std::streamsize>(content.size()));
    out.close();
    if (!out) throw InputError(fmt::format("{}: write failed (disk full?)", path.string()));
  });
}

std::string ReadTextFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    throw InputError(
        fmt::format("{}: cannot open: {}", path.string(),
                    fs::exists(path) ? "permission denied or not a file" : "no such file"));
  }
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace linesight
