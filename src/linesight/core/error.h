// Two error paths (CONVENTIONS.md §3):
//  * Bad input at the API / CLI boundary -> a typed exception whose message a user can act on
//    (it names the file, field or value and what was expected).
//  * Broken internal invariants -> LS_CHECK, which aborts with file:line.
// The library never calls exit() and never prints to stdout.
#pragma once

#include <stdexcept>
#include <string>

#include <fmt/format.h>

namespace linesight {

// Input the user gave us is wrong (a file is missing or malformed, a value is out of range).
// The CLI maps it to exit code 1.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The command line itself is wrong (unknown flag, unknown method name, missing argument).
// The CLI maps it to exit code 2.
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// An Options struct holds a value that breaks a rule. Message: "<Struct>.<field> = <value>:
// <rule>".
class OptionError : public InputError {
 public:
  using InputError::InputError;
};

// Throws OptionError naming the struct field, its value and the rule when `ok` is false.
template <typename T>
void CheckOption(bool ok, const char* field, const T& value, const char* rule) {
  if (!ok) throw OptionError(fmt::format("{} = {}: {}", field, value, rule));
}

[[noreturn]] void CheckFailed(const char* file, int line, const char* condition,
                              const std::string& message);

}  // namespace linesight

// Internal invariant: aborts the process with file:line and the failed condition.
#define LS_CHECK(cond)                                                    \
  do {                                                                    \
    if (!(cond)) ::linesight::CheckFailed(__FILE__, __LINE__, #cond, ""); \
  } while (false)

#define LS_CHECK_MSG(cond, ...)                                                                   \
  do {                                                                                            \
    if (!(cond)) ::linesight::CheckFailed(__FILE__, __LINE__, #cond, ::fmt::format(__VA_ARGS__)); \
  } while (false)
