#include "linesight/core/key_value.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace linesight {
namespace {

using ::testing::HasSubstr;

std::string UsageMessage(const std::function<void()>& body) {
  try {
    body();
  } catch (const UsageError& e) {
    return e.what();
  }
  return "(no UsageError)";
}

TEST(ParseKeyValues, SplitsEntriesAndKeepsTheLastValueOfAKey) {
  const auto values = ParseKeyValues("--param", {"p1=8,p2=32", "mode=", "p1=10"});
  EXPECT_EQ(values, (std::map<std::string, std::string>{{"mode", ""}, {"p1", "10"}, {"p2", "32"}}));
  EXPECT_TRUE(ParseKeyValues("--param", {}).empty());
}

TEST(ParseKeyValues, ErrorsNameTheFlagTheItemAndTheForm) {
  EXPECT_EQ(UsageMessage([] { ParseKeyValues("--param", {"p1=8,p2"}); }),
            "--param 'p2': expected key=value");
  EXPECT_EQ(UsageMessage([] { ParseKeyValues("--ranging", {"=3"}); }),
            "--ranging '=3': expected key=value");
  EXPECT_EQ(UsageMessage([] { ParseKeyValues("--param", {""}); }),
            "--param '': expected key=value");
}

TEST(ParseKeyValues, StrictSyntaxRejectsEmptyValuesAndRepeats) {
  KeyValueSyntax strict;
  strict.separator = ':';
  strict.allow_empty_value = false;
  strict.allow_repeats = false;
  strict.form = "NAME[:key=value...]";
  EXPECT_EQ(ParseKeyValues("m", {"paths=8:p1=10"}, strict),
            (std::map<std::string, std::string>{{"p1", "10"}, {"paths", "8"}}));
  EXPECT_EQ(UsageMessage([&] { ParseKeyValues("m", {"paths="}, strict); }),
            "m 'paths=': expected NAME[:key=value...]");
  EXPECT_EQ(UsageMessage([&] { ParseKeyValues("m", {"paths=4:paths=8"}, strict); }),
            "m 'paths': set twice");
}

TEST(OptionRange, ContainsRespectsOpenAndClosedEnds) {
  EXPECT_TRUE(OptionRange::Closed(0, 1).Contains(0));
  EXPECT_TRUE(OptionRange::Closed(0, 1).Contains(1));
  EXPECT_FALSE(OptionRange::Closed(0, 1).Contains(1.0001));
  EXPECT_FALSE(OptionRange::OpenClosed(0, 1).Contains(0));
  EXPECT_TRUE(OptionRange::OpenClosed(0, 1).Contains(1));
  EXPECT_FALSE(OptionRange::ClosedOpen(0, 1).Contains(1));
  EXPECT_FALSE(OptionRange::Above(0).Contains(0));
  EXPECT_TRUE(OptionRange::AtLeast(3).Contains(3));
  EXPECT_TRUE(OptionRange::Any().Contains(-1e300));
  EXPECT_EQ(OptionRange::OpenClosed(0, 0.5).ToString(), "in (0, 0.5]");
  EXPECT_EQ(OptionRange::AtLeast(3).ToString(), ">= 3");
  EXPECT_EQ(OptionRange::Above(0).ToString(), "> 0");
  EXPECT_EQ(OptionRange::Any().ToString(), "");
}

struct Inner {
  double ratio = 0.25;
};
struct Settings {
  bool enabled = true;
  int mode = 2;
  double weight = 1.5;
  Inner inner;
};

OptionTable<Settings> Table() {
  OptionTable<Settings> table;
  table.Add("enabled", OptionField(&Settings::enabled), "turns it on")
      .Add("mode", OptionField(&Settings::mode), OptionRange::Closed(0, 3), "which mode")
      .Add("weight", OptionField(&Settings::weight), OptionRange::AtLeast(0), "how much")
      .Add("ratio", OptionField(&Settings::inner, &Inner::ratio), OptionRange::OpenClosed(0, 1),
           "nested member");
  return table;
}

TEST(OptionTable, AppliesValuesOfEveryTypeIncludingNestedMembers) {
  Settings s;
  Table().Apply("--x", {{"enabled", "0"}, {"mode", "3"}, {"weight", "0.5"}, {"ratio", "1"}}, &s);
  EXPECT_FALSE(s.enabled);
  EXPECT_EQ(s.mode, 3);
  EXPECT_EQ(s.weight, 0.5);
  EXPECT_EQ(s.inner.ratio, 1.0);
  Table().Apply("--x", {{"enabled", "true"}}, &s);
  EXPECT_TRUE(s.enabled);
}

TEST(OptionTable, RejectsValuesOutsideTheirTypeOrRange) {
  const OptionTable<Settings> table = Table();
  Settings s;
  auto apply = [&](const std::string& key, const std::string& value) {
    return UsageMessage([&] { table.Apply("--x", {{key, value}}, &s); });
  };
  EXPECT_EQ(apply("mode", "2.5"), "--x 'mode=2.5': expected a whole number in [0, 3]");
  EXPECT_EQ(apply("mode", "4"), "--x 'mode=4': expected a whole number in [0, 3]");
  EXPECT_EQ(apply("mode", "1e300"), "--x 'mode=1e300': expected a whole number in [0, 3]");
  EXPECT_EQ(apply("weight", "-1"), "--x 'weight=-1': expected a number >= 0");
  EXPECT_EQ(apply("weight", "inf"), "--x 'weight=inf': expected a number >= 0");
  EXPECT_EQ(apply("weight", "1x"), "--x 'weight=1x': expected a number >= 0");
  EXPECT_EQ(apply("ratio", "0"), "--x 'ratio=0': expected a number in (0, 1]");
  EXPECT_EQ(apply("enabled", "2"), "--x 'enabled=2': expected 0 or 1");
  EXPECT_EQ(apply("speed", "1"),
            "--x 'speed=1': unknown key (valid: enabled, mode, weight, ratio)");
  // Nothing was applied by the rejected settings.
  EXPECT_EQ(s.mode, 2);
  EXPECT_EQ(s.weight, 1.5);
}

TEST(OptionTable, HelpListsEveryKeyWithItsDefaultAndRange) {
  const std::string help = Table().Help();
  EXPECT_THAT(help, HasSubstr("  enabled = 1 (0 or 1): turns it on\n"));
  EXPECT_THAT(help, HasSubstr("  mode = 2 (whole number in [0, 3]): which mode\n"));
  EXPECT_THAT(help, HasSubstr("  weight = 1.5 (number >= 0): how much\n"));
  EXPECT_THAT(help, HasSubstr("  ratio = 0.25 (number in (0, 1]): nested member\n"));
  Settings changed;
  changed.mode = 1;
  EXPECT_THAT(Table().Help(changed), HasSubstr("  mode = 1 "));
}

TEST(OptionTable, SerialisesTheEffectiveSettings) {
  Settings s;
  s.inner.ratio = 0.75;
  const nlohmann::json j = Table().ToJson(s);
  EXPECT_EQ(j, nlohmann::json({{"enabled", true}, {"mode", 2}, {"weight", 1.5}, {"ratio", 0.75}}));
  EXPECT_TRUE(j["enabled"].is_boolean());
  EXPECT_TRUE(j["mode"].is_number_integer());
}

}  // namespace
}  // namespace linesight
