#include "linesight/io/json_io.h"

#include <algorithm>
#include <string>

#include <fmt/format.h>

#include "linesight/core/atomic_file.h"
#include "linesight/core/error.h"

namespace linesight {
namespace fs = std::filesystem;

void WriteJson(const fs::path& path, const nlohmann::json& json) {
  std::string text;
  try {
    text = json.dump(2) + "\n";
  } catch (const nlohmann::json::exception& e) {
    // dump() throws on strings that are not valid UTF-8.
    throw InputError(fmt::format("{}: cannot write JSON: {}", path.string(), e.what()));
  }
  WriteTextAtomic(path, text);
}

nlohmann::json ReadJson(const fs::path& path) {
  const std::string text = ReadTextFile(path);
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    // e.byte is the 1-based position of the offending character; turn it into line:column.
    const std::size_t offset = std::min<std::size_t>(e.byte == 0 ? 0 : e.byte - 1, text.size());
    const std::size_t line = 1 + std::count(text.begin(), text.begin() + offset, '\n');
    const std::size_t line_start = text.rfind('\n', offset == 0 ? 0 : offset - 1);
    const std::size_t column =
        offset - (line_start == std::string::npos || offset == 0 ? 0 : line_start + 1) + 1;
    throw InputError(
        fmt::format("{}:{}:{}: invalid JSON: {}", path.string(), line, column, e.what()));
  }
}

}  // namespace linesight
