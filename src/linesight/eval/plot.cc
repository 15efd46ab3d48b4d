#include "linesight/eval/plot.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "linesight/core/atomic_file.h"

namespace linesight {
namespace {

constexpr const char* kPalette[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd",
                                    "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"};

std::string Escape(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '&':
        out += "&amp;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

// "Nice" tick step for a range (1, 2 or 5 times a power of ten).
double NiceStep(double range, int target_ticks) {
  const double raw = range / std::max(target_ticks, 1);
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0, 10.0}) {
    if (raw <= m * magnitude) return m * magnitude;
  }
  return 10 * magnitude;
}

// Chart body translated to (ox, oy) with the given size.
std::string ChartGroup(const LineChart& chart, int ox, int oy, int width, int height) {
  const double left = 62, right = 12, top = 30, bottom = 48;
  const double pw = width - left - right, ph = height - top - bottom;
  const size_t n = chart.x_ticks.empty() ? chart.x_values.size() : chart.x_ticks.size();
  double ymin = std::numeric_limits<double>::infinity(), ymax = -ymin;
  for (const auto& s : chart.series) {
    for (double v : s.y) {
      if (!std::isfinite(v) || (chart.log_y && v <= 0)) continue;
      ymin = std::min(ymin, v);
      ymax = std::max(ymax, v);
    }
  }
  if (!std::isfinite(ymin)) ymin = 0, ymax = 1;
  auto ty = [&](double v) { return chart.log_y ? std::log10(v) : v; };
  double lo = chart.log_y ? std::floor(ty(ymin)) : std::min(0.0, ymin);
  double hi = chart.log_y ? std::ceil(ty(ymax)) : ymax;
  if (hi <= lo) hi = lo + 1;
  if (!chart.log_y) hi += (hi - lo) * 0.05;
  double xmin = 0, xmax = n > 1 ? static_cast<double>(n - 1) : 1;
  if (chart.x_ticks.empty() && n > 0) {
    xmin = *std::min_element(chart.x_values.begin(), chart.x_values.end());
    xmax = *std::max_element(chart.x_values.begin(), chart.x_values.end());
    if (xmax <= xmin) xmax = xmin + 1;
  }
  auto px = [&](size_t i) {
    const double x = chart.x_ticks.empty() ? chart.x_values[i] : static_cast<double>(i);
    const double pad = chart.x_ticks.empty() ? 0.0 : 0.5;
    return left + pw * (x - xmin + pad) / (xmax - xmin + 2 * pad);
  };
  auto py = [&](double v) { return top + ph * (1 - (ty(v) - lo) / (hi - lo)); };

  std::string svg = fmt::format("<g transform=\"translate({},{})\">\n", ox, oy);
  svg += fmt::format("<rect x=\"0\" y=\"0\" width=\"{}\" height=\"{}\" fill=\"white\"/>\n", width,
                     height);
  svg += fmt::format(
      "<text x=\"{}\" y=\"18\" text-anchor=\"middle\" font-size=\"14\" "
      "font-weight=\"bold\">{}</text>\n",
      width / 2, Escape(chart.title));
  // Y grid and labels.
  if (chart.log_y) {
    for (double e = lo; e <= hi + 1e-9; e += 1) {
      const double y = top + ph * (1 - (e - lo) / (hi - lo));
      svg +=
          fmt::format("<line x1=\"{}\" y1=\"{:.1f}\" x2=\"{}\" y2=\"{:.1f}\" stroke=\"#ddd\"/>\n",
                      left, y, left + pw, y);
      svg += fmt::format(
          "<text x=\"{}\" y=\"{:.1f}\" text-anchor=\"end\" font-size=\"11\">{:g}</text>\n",
          left - 5, y + 4, std::pow(10.0, e));
    }
  } else {
    const double step = NiceStep(hi - lo, 5);
    for (double v = std::ceil(lo / step) * step; v <= hi + 1e-9; v += step) {
      const double y = py(v);
      svg +=
          fmt::format("<line x1=\"{}\" y1=\"{:.1f}\" x2=\"{}\" y2=\"{:.1f}\" stroke=\"#ddd\"/>\n",
                      left, y, left + pw, y);
      svg += fmt::format(
          "<text x=\"{}\" y=\"{:.1f}\" text-anchor=\"end\" font-size=\"11\">{:g}</text>\n",
          left - 5, y + 4, v);
    }
  }
  // X labels.
  for (size_t i = 0; i < n; ++i) {
    const std::string label =
        chart.x_ticks.empty() ? fmt::format("{:g}", chart.x_values[i]) : chart.x_ticks[i];
    svg += fmt::format(
        "<text x=\"{:.1f}\" y=\"{}\" text-anchor=\"middle\" font-size=\"11\">{}</text>\n", px(i),
        top + ph + 16, Escape(label));
  }
  svg += fmt::format(
      "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"#333\"/>\n", left,
      top, pw, ph);
  svg += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\" font-size=\"12\">{}</text>\n",
                     left + pw / 2, height - 8, Escape(chart.x_label));
  svg += fmt::format(
      "<text x=\"14\" y=\"{}\" text-anchor=\"middle\" font-size=\"12\" transform=\"rotate(-90 14 "
      "{})\">{}</text>\n",
      top + ph / 2, top + ph / 2, Escape(chart.y_label));
  // Series and legend.
  for (size_t s = 0; s < chart.series.size(); ++s) {
    const PlotSeries& series = chart.series[s];
    const char* colour = kPalette[s % std::size(kPalette)];
    std::string points;
    for (size_t i = 0; i < std::min(n, series.y.size()); ++i) {
      const double v = series.y[i];
      if (!std::isfinite(v) || (chart.log_y && v <= 0)) continue;
      points += fmt::format("{:.1f},{:.1f} ", px(i), py(v));
      svg += fmt::format("<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"3\" fill=\"{}\"/>\n", px(i),
                         py(v), colour);
    }
    svg +=
        fmt::format("<polyline points=\"{}\" fill=\"none\" stroke=\"{}\" stroke-width=\"2\"{}/>\n",
                    points, colour, series.dashed ? " stroke-dasharray=\"6,4\"" : "");
    const double ly = top + 14 + 15 * static_cast<double>(s);
    svg += fmt::format(
        "<line x1=\"{}\" y1=\"{:.1f}\" x2=\"{}\" y2=\"{:.1f}\" stroke=\"{}\" "
        "stroke-width=\"2\"{}/>\n",
        left + 8, ly - 4, left + 28, ly - 4, colour,
        series.dashed ? " stroke-dasharray=\"4,3\"" : "");
    svg += fmt::format("<text x=\"{}\" y=\"{:.1f}\" font-size=\"11\">{}</text>\n", left + 32, ly,
                       Escape(series.name));
  }
  svg += "</g>\n";
  return svg;
}

}  // namespace

std::string LineChart::ToSvg(int width, int height) const {
  return fmt::format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{}\" height=\"{}\" "
      "font-family=\"sans-serif\">\n{}</svg>\n",
      width, height, ChartGroup(*this, 0, 0, width, height));
}

void WriteSvg(const std::filesystem::path& path, const LineChart& chart) {
  WriteTextAtomic(path, chart.ToSvg());
}

void WriteSvgPanels(const std::filesystem::path& path, const std::vector<LineChart>& charts,
                    int columns, int panel_width, int panel_height) {
  columns = std::max(1, columns);
  const int rows = (static_cast<int>(charts.size()) + columns - 1) / columns;
  std::string body;
  for (size_t i = 0; i < charts.size(); ++i) {
    body += ChartGroup(charts[i], static_cast<int>(i % columns) * panel_width,
                       static_cast<int>(i / columns) * panel_height, panel_width, panel_height);
  }
  WriteTextAtomic(
      path, fmt::format("<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{}\" height=\"{}\" "
                        "font-family=\"sans-serif\">\n{}</svg>\n",
                        columns * panel_width, rows * panel_height, body));
}

}  // namespace linesight
