#include "linesight/core/key_value.h"

#include <stdexcept>

namespace linesight {

std::map<std::string, std::string> ParseKeyValues(std::string_view flag,
                                                  const std::vector<std::string>& entries,
                                                  const KeyValueSyntax& syntax) {
  std::map<std::string, std::string> out;
  for (const std::string& entry : entries) {
    size_t begin = 0;
    while (true) {
      const size_t end = entry.find(syntax.separator, begin);
      const std::string item =
          entry.substr(begin, end == std::string::npos ? std::string::npos : end - begin);
      const size_t eq = item.find('=');
      if (eq == std::string::npos || eq == 0 ||
          (!syntax.allow_empty_value && eq + 1 == item.size())) {
        throw UsageError(fmt::format("{} '{}': expected {}", flag, item, syntax.form));
      }
      std::string key = item.substr(0, eq);
      if (!syntax.allow_repeats && out.count(key)) {
        throw UsageError(fmt::format("{} '{}': set twice", flag, key));
      }
      out[std::move(key)] = item.substr(eq + 1);
      if (end == std::string::npos) break;
      begin = end + 1;
    }
  }
  return out;
}

bool OptionRange::Contains(double value) const {
  const bool above = lo_open ? value > lo : value >= lo;
  const bool below = hi_open ? value < hi : value <= hi;
  return above && below;
}

std::string OptionRange::ToString() const {
  const bool bounded_below = std::isfinite(lo), bounded_above = std::isfinite(hi);
  if (bounded_below && bounded_above) {
    return fmt::format("in {}{}, {}{}", lo_open ? '(' : '[', lo, hi, hi_open ? ')' : ']');
  }
  if (bounded_below) return fmt::format("{} {}", lo_open ? ">" : ">=", lo);
  if (bounded_above) return fmt::format("{} {}", hi_open ? "<" : "<=", hi);
  return "";
}

namespace detail {

bool ParseFiniteNumber(const std::string& text, double* value) {
  try {
    size_t used = 0;
    *value = std::stod(text, &used);
    return used == text.size() && std::isfinite(*value);
  } catch (const std::exception&) {
    return false;
  }
}

bool ParseBoolText(const std::string& text, bool* value) {
  if (text == "1" || text == "true" || text == "on") {
    *value = true;
    return true;
  }
  if (text == "0" || text == "false" || text == "off") {
    *value = false;
    return true;
  }
  return false;
}

std::string FormatOptionValue(OptionType type, double value) {
  switch (type) {
    case OptionType::kBool:
      return value != 0.0 ? "1" : "0";
    case OptionType::kInt:
      return fmt::format("{}", static_cast<long long>(value));
    case OptionType::kNumber:
      break;
  }
  return fmt::format("{}", value);
}

}  // namespace detail
}  // namespace linesight
