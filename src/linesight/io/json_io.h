#pragma once

#include <filesystem>

#include <nlohmann/json.hpp>

namespace linesight {

// Writes a JSON report (2-space indent) atomically; "-" writes to stdout.
void WriteJson(const std::filesystem::path& path, const nlohmann::json& json);
// Reads JSON; throws InputError naming the file and the parse error position.
nlohmann::json ReadJson(const std::filesystem::path& path);

}  // namespace linesight
