// Atomic output: write to a temporary file beside the target, then rename over it, so that a crash
// or an error never leaves a partially written output file behind.
#pragma once

#include <filesystem>
#include <functional>
#include <string_view>

namespace linesight {

// Calls `write(tmp_path)` to produce the content at a temporary path in the target's folder, then
// renames it onto `path`. If `write` throws, the temporary file is removed and the exception
// propagates; `path` is left untouched. Throws InputError if the folder does not exist or the
// rename fails. The temporary file keeps the target's extension so that extension-sniffing writers
// (cv::imwrite) still work.
void WriteFileAtomic(const std::filesystem::path& path,
                     const std::function<void(const std::filesystem::path& tmp_path)>& write);

// Writes bytes atomically. `path` "-" writes to stdout instead.
void WriteTextAtomic(const std::filesystem::path& path, std::string_view content);

// Reads a whole file; throws InputError naming the file if it cannot be read.
std::string ReadTextFile(const std::filesystem::path& path);

}  // namespace linesight
