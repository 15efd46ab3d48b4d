// Small SVG charts for reports (people would rather look than read).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace linesight {

struct PlotSeries {
  std::string name;
  std::vector<double> y;  // one value per x position; NaN = no point
  bool dashed = false;
};

struct LineChart {
  std::string title;
  std::string x_label, y_label;
  std::vector<std::string> x_ticks;  // categorical x axis: one label per position
  std::vector<double> x_values;      // numeric x axis (used when x_ticks is empty)
  std::vector<PlotSeries> series;
  bool log_y = false;

  // SVG document text.
  std::string ToSvg(int width = 640, int height = 400) const;
};

// Writes the chart atomically.
void WriteSvg(const std::filesystem::path& path, const LineChart& chart);

// Several charts side by side in one SVG (panels of `panel_width` x `panel_height`, `columns` per
// row).
void WriteSvgPanels(const std::filesystem::path& path, const std::vector<LineChart>& charts,
                    int columns, int panel_width = 420, int panel_height = 300);

}  // namespace linesight
