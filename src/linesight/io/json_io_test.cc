#include "linesight/io/json_io.h"

#include <gtest/gtest.h>

#include "linesight/core/atomic_file.h"
#include "linesight/io/io_test_util.h"

namespace linesight {
namespace {
using testing::ExpectInputError;

class JsonIoTest : public testing::TempDirTest {};

TEST_F(JsonIoTest, RoundTripWithTwoSpaceIndent) {
  const nlohmann::json report = {{"scene", "tsukuba"}, {"bad1", 3.25}, {"methods", {"bm", "sgbm"}}};
  WriteJson(dir_ / "r.json", report);
  EXPECT_EQ(ReadJson(dir_ / "r.json"), report);
  const std::string text = ReadTextFile(dir_ / "r.json");
  EXPECT_NE(text.find("\n  \"bad1\": 3.25"), std::string::npos) << text;
  EXPECT_EQ(text.back(), '\n');
  EXPECT_EQ(Files(), std::vector<std::string>{"r.json"});
}

TEST_F(JsonIoTest, StdoutDash) {
  ::testing::internal::CaptureStdout();
  WriteJson("-", nlohmann::json{{"a", 1}});
  EXPECT_EQ(::testing::internal::GetCapturedStdout(), "{\n  \"a\": 1\n}\n");
}

TEST_F(JsonIoTest, ParseErrorNamesFileLineAndColumn) {
  WriteTextAtomic(dir_ / "bad.json", "{\n  \"a\": 1,\n  \"b\": tru\n}\n");
  ExpectInputError([&] { ReadJson(dir_ / "bad.json"); }, {"bad.json:3:", "invalid JSON"});
  WriteTextAtomic(dir_ / "cut.json", "{\"a\": [1, 2");
  ExpectInputError([&] { ReadJson(dir_ / "cut.json"); }, {"cut.json:1:", "invalid JSON"});
  ExpectInputError([&] { ReadJson(dir_ / "missing.json"); }, {"missing.json", "no such file"});
}

TEST_F(JsonIoTest, InvalidUtf8IsAnInputErrorAndLeavesNoFile) {
  ExpectInputError(
      [&] {
        WriteJson(dir_ / "x.json", nlohmann::json{{"s", std::string("\xff\xfe")}});
      },
      {"x.json"});
  EXPECT_TRUE(Files().empty());
}

}  // namespace
}  // namespace linesight
