// key=value settings as the command line gives them (`--param`, `--ranging`, `bench --methods
// NAME:key=value`), and OptionTable, the declarative table of one options struct's settings: one
// row per key naming the member it sets, its type, its allowed range and one line of doc, from
// which values are applied with range checks, the help text is written and the effective settings
// are serialised (CONVENTIONS.md §2, §13). The defaults are the struct's in-class defaults.
#pragma once

#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include "linesight/core/error.h"

namespace linesight {

struct KeyValueSyntax {
  char separator = ',';            // between the items of one entry ("p1=8,p2=32")
  bool allow_empty_value = true;   // "key=" sets key to ""
  bool allow_repeats = true;       // a key given again replaces its value; false = UsageError
  std::string form = "key=value";  // the expected form, as error messages name it
};

// Parses the entries of `flag` (each one item or several joined by syntax.separator) into
// key -> value. Throws UsageError naming the flag, the item and the expected form, e.g.
// "--param 'p1': expected key=value".
std::map<std::string, std::string> ParseKeyValues(std::string_view flag,
                                                  const std::vector<std::string>& entries,
                                                  const KeyValueSyntax& syntax = {});

// The values a setting accepts: lo..hi, each end closed or open (infinite = unbounded).
struct OptionRange {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool lo_open = false, hi_open = false;

  static OptionRange Any() { return {}; }
  static OptionRange Closed(double lo, double hi) { return {lo, hi, false, false}; }
  static OptionRange AtLeast(double lo) {
    return Closed(lo, std::numeric_limits<double>::infinity());
  }
  static OptionRange Above(double lo) {
    return {lo, std::numeric_limits<double>::infinity(), true, false};
  }
  static OptionRange OpenClosed(double lo, double hi) { return {lo, hi, true, false}; }
  static OptionRange ClosedOpen(double lo, double hi) { return {lo, hi, false, true}; }

  bool Contains(double value) const;
  // "in [0, 1]", "in (0, 0.5]", ">= 3", "> 0", or "" when unbounded.
  std::string ToString() const;
};

enum class OptionType { kBool, kInt, kNumber };

namespace detail {
// Parses `text` as a finite number (all of it); false if it is not one.
bool ParseFiniteNumber(const std::string& text, double* value);
// Parses 0 / 1 / true / false / on / off; false if it is none of them.
bool ParseBoolText(const std::string& text, bool* value);
std::string FormatOptionValue(OptionType type, double value);
}  // namespace detail

// Accessor of a (nested) member for OptionTable::Add: OptionField(&Outer::inner, &Inner::value)
// maps an Outer to its inner.value.
template <typename... Members>
auto OptionField(Members... path) {
  return [path...](auto& object) -> auto& { return (object.*....*path); };
}

template <typename T>
class OptionTable {
 public:
  struct Row {
    std::string key;
    OptionType type = OptionType::kNumber;
    OptionRange range;
    std::string doc;
    std::function<double(const T&)> get;
    std::function<void(T&, double)> set;
  };

  // A bool, int or double setting: `field(options)` is a reference to the member, for a const and
  // a mutable T (OptionField).
  // Bools take 0 / 1 (or true / false, on / off) and ignore `range`.
  template <typename Field>
  OptionTable& Add(std::string key, Field field, OptionRange range, std::string doc) {
    using Value = std::remove_cv_t<std::remove_reference_t<decltype(field(std::declval<T&>()))>>;
    static_assert(
        std::is_same_v<Value, bool> || std::is_same_v<Value, int> || std::is_same_v<Value, double>,
        "OptionTable settings are bool, int or double members");
    Row row;
    row.key = std::move(key);
    row.range = range;
    row.doc = std::move(doc);
    if constexpr (std::is_same_v<Value, bool>) {
      row.type = OptionType::kBool;
      row.range = OptionRange::Closed(0, 1);
    } else if constexpr (std::is_same_v<Value, int>) {
      row.type = OptionType::kInt;
    }
    row.get = [field](const T& options) { return static_cast<double>(field(options)); };
    row.set = [field](T& options, double value) { field(options) = static_cast<Value>(value); };
    rows_.push_back(std::move(row));
    return *this;
  }
  template <typename Field>
  OptionTable& Add(std::string key, Field field, std::string doc) {
    return Add(std::move(key), field, OptionRange::Any(), std::move(doc));
  }

  const std::vector<Row>& rows() const { return rows_; }
  std::vector<std::string> Keys() const {
    std::vector<std::string> keys;
    for (const Row& row : rows_) keys.push_back(row.key);
    return keys;
  }

  // Applies key -> value text to `options`. Throws UsageError naming `flag` and the setting with
  // the value it expected ("--ranging 'edge_min_rows=2.5': expected a whole number in [1,
  // 1000000]"), or, for an unknown key, the valid keys.
  void Apply(std::string_view flag, const std::map<std::string, std::string>& values,
             T* options) const {
    for (const auto& [key, text] : values) {
      const Row* row = Find(key);
      const std::string setting = key + "=" + text;
      if (!row) {
        throw UsageError(fmt::format("{} '{}': unknown key (valid: {})", flag, setting,
                                     fmt::join(Keys(), ", ")));
      }
      double value = 0.0;
      if (row->type == OptionType::kBool) {
        bool b = false;
        if (!detail::ParseBoolText(text, &b)) {
          throw UsageError(fmt::format("{} '{}': expected 0 or 1", flag, setting));
        }
        value = b ? 1.0 : 0.0;
      } else {
        const bool whole = row->type == OptionType::kInt;
        const bool number = detail::ParseFiniteNumber(text, &value);
        const bool fits = !whole || (value == std::floor(value) &&
                                     std::abs(value) <= std::numeric_limits<int>::max());
        if (!number || !fits || !row->range.Contains(value)) {
          const std::string range = row->range.ToString();
          throw UsageError(fmt::format("{} '{}': expected {}{}{}", flag, setting,
                                       whole ? "a whole number" : "a number",
                                       range.empty() ? "" : " ", range));
        }
      }
      row->set(*options, value);
    }
  }

  // One line per key, "  key = default (accepted values): doc", with the defaults of `defaults`.
  std::string Help(const T& defaults = T{}) const {
    std::string out;
    for (const Row& row : rows_) {
      const std::string range = row.type == OptionType::kBool ? "" : row.range.ToString();
      out += fmt::format("  {} = {} ({}{}{}): {}\n", row.key,
                         detail::FormatOptionValue(row.type, row.get(defaults)),
                         row.type == OptionType::kBool  ? "0 or 1"
                         : row.type == OptionType::kInt ? "whole number"
                                                        : "number",
                         range.empty() ? "" : " ", range, row.doc);
    }
    return out;
  }

  // {key: value} of every setting of `options` (bools as true / false).
  nlohmann::json ToJson(const T& options) const {
    nlohmann::json out = nlohmann::json::object();
    for (const Row& row : rows_) {
      const double value = row.get(options);
      switch (row.type) {
        case OptionType::kBool:
          out[row.key] = value != 0.0;
          break;
        case OptionType::kInt:
          out[row.key] = static_cast<int>(value);
          break;
        case OptionType::kNumber:
          out[row.key] = value;
          break;
      }
    }
    return out;
  }

 private:
  const Row* Find(const std::string& key) const {
    for (const Row& row : rows_) {
      if (row.key == key) return &row;
    }
    return nullptr;
  }

  std::vector<Row> rows_;
};

}  // namespace linesight
