#include "linesight/io/opencv_plugin.h"

#include <dlfcn.h>

#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <stdexcept>

#include <fmt/format.h>
#include <fmt/ranges.h>

namespace linesight {
namespace {

namespace fs = std::filesystem;

constexpr const char* kPluginFile = "linesight_opencv_plugin.so";

struct Loaded {
  const OpenCvPlugin* plugin = nullptr;
  std::vector<std::string> tried;  // "<path>: <why not>"
};

// The folders searched, in order. Set at build time: the install prefix's and the build tree's.
std::vector<fs::path> PluginFolders() {
  std::vector<fs::path> folders;
  if (const char* dir = std::getenv("LINESIGHT_PLUGIN_DIR"); dir != nullptr && *dir != '\0') {
    folders.emplace_back(dir);
  }
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) folders.push_back(exe.parent_path().parent_path() / LINESIGHT_PLUGIN_RELATIVE_DIR);
  folders.emplace_back(LINESIGHT_PLUGIN_INSTALL_DIR);
#ifdef LINESIGHT_PLUGIN_BUILD_DIR
  folders.emplace_back(LINESIGHT_PLUGIN_BUILD_DIR);
#endif
  return folders;
}

Loaded Load() {
  Loaded loaded;
  for (const fs::path& folder : PluginFolders()) {
    const fs::path path = folder / kPluginFile;
    std::error_code ec;
    if (!fs::exists(path, ec)) {
      loaded.tried.push_back(fmt::format("{}: no such file", path.string()));
      continue;
    }
    void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (handle == nullptr) {
      loaded.tried.push_back(fmt::format("{}: {}", path.string(), dlerror()));
      continue;
    }
    auto entry =
        reinterpret_cast<LinesightOpenCvPluginEntry>(dlsym(handle, "linesight_opencv_plugin"));
    int abi = 0;
    const OpenCvPlugin* plugin = entry != nullptr ? entry(&abi) : nullptr;
    if (plugin == nullptr || abi != kOpenCvPluginAbi) {
      loaded.tried.push_back(
          fmt::format("{}: built for another linesight version (interface {}, expected {})",
                      path.string(), abi, kOpenCvPluginAbi));
      dlclose(handle);
      continue;
    }
    // The handle stays open for the life of the process.
    loaded.plugin = plugin;
    return loaded;
  }
  return loaded;
}

std::once_flag g_once;
Loaded* g_loaded = nullptr;

const Loaded& LoadOnce() {
  std::call_once(g_once, [] { g_loaded = new Loaded(Load()); });
  return *g_loaded;
}

}  // namespace

const OpenCvPlugin& LoadOpenCvPlugin(std::string_view needed_for) {
  const Loaded& loaded = LoadOnce();
  if (loaded.plugin == nullptr) {
    throw std::runtime_error(fmt::format(
        "{} needs OpenCV's imgcodecs / videoio / ximgproc through {}, which was not found or "
        "not usable ({}); set LINESIGHT_PLUGIN_DIR to the folder that holds it",
        needed_for, kPluginFile, fmt::join(loaded.tried, "; ")));
  }
  return *loaded.plugin;
}

}  // namespace linesight
