#include "linesight/eval/plot.h"

#include <cmath>
#include <regex>

#include <gtest/gtest.h>

namespace linesight {
namespace {

int Count(const std::string& text, const std::string& what) {
  int n = 0;
  for (size_t pos = text.find(what); pos != std::string::npos; pos = text.find(what, pos + 1)) ++n;
  return n;
}

TEST(LineChart, DrawsEveryFinitePointAndEscapesText) {
  LineChart chart;
  chart.title = "a < b";
  chart.x_ticks = {"clean", "gauss:0.1", "sp:0.15"};
  chart.series = {{"isgm", {1.0, 2.0, 3.0}}, {"bm & co", {2.0, NAN, 5.0}, true}};
  const std::string svg = chart.ToSvg();
  EXPECT_EQ(svg.rfind("<svg", 0), 0u);
  EXPECT_EQ(Count(svg, "<circle"), 5);
  EXPECT_EQ(Count(svg, "<polyline"), 2);
  EXPECT_NE(svg.find("a &lt; b"), std::string::npos);
  EXPECT_NE(svg.find("bm &amp; co"), std::string::npos);
  EXPECT_NE(svg.find("stroke-dasharray"), std::string::npos);
}

TEST(LineChart, HigherValuesAreDrawnHigher) {
  LineChart chart;
  chart.x_values = {1, 2};
  chart.series = {{"s", {10.0, 20.0}}};
  const std::string svg = chart.ToSvg();
  std::smatch m;
  ASSERT_TRUE(std::regex_search(
      svg, m, std::regex("cy=\"([0-9.]+)\"[^\\n]*\\n<circle[^\\n]*cy=\"([0-9.]+)\"")));
  EXPECT_GT(std::stod(m[1]), std::stod(m[2]));  // SVG y grows downwards
}

TEST(LineChart, LogAxisSkipsNonPositive) {
  LineChart chart;
  chart.log_y = true;
  chart.x_values = {1, 2, 3};
  chart.series = {{"s", {0.0, 0.1, 10.0}}};
  EXPECT_EQ(Count(chart.ToSvg(), "<circle"), 2);
}

}  // namespace
}  // namespace linesight
