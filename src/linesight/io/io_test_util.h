// Test helpers shared by the io tests (not part of the library).
#pragma once

#include <unistd.h>

#include <filesystem>
#include <functional>
#include <initializer_list>
#include <string>

#include <gtest/gtest.h>

#include "linesight/core/error.h"

namespace linesight::testing {

// A fresh folder per test, removed afterwards.
class TempDirTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = std::filesystem::temp_directory_path() /
           ("linesight_io_" + std::to_string(::getpid()) + "_" + info->test_suite_name() + "_" +
            info->name());
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  // Names of the files in the folder (to check that failed writes leave nothing behind).
  std::vector<std::string> Files() const {
    std::vector<std::string> names;
    for (const auto& entry : std::filesystem::directory_iterator(dir_))
      names.push_back(entry.path().filename());
    return names;
  }
  std::filesystem::path dir_;
};

// Runs `body`, expects an InputError whose message contains every one of `parts`; returns the
// message.
inline std::string ExpectInputError(const std::function<void()>& body,
                                    std::initializer_list<std::string> parts) {
  try {
    body();
  } catch (const InputError& e) {
    const std::string message = e.what();
    for (const std::string& part : parts) {
      EXPECT_NE(message.find(part), std::string::npos)
          << "message \"" << message << "\" lacks \"" << part << "\"";
    }
    return message;
  }
  ADD_FAILURE() << "expected an InputError";
  return {};
}

inline std::filesystem::path SharedData(const std::string& relative) {
  return std::filesystem::path(LINESIGHT_SHARED_DATA_DIR) / relative;
}

}  // namespace linesight::testing
