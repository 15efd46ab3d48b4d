// The calib.txt of Middlebury 2014 and ETH3D scenes: "key=value" lines,
//   cam0=[f 0 cx; 0 f cy; 0 0 1]   left camera matrix (px)
//   cam1=[...]                     right camera matrix
//   doffs=...                      x difference of the principal points (px): Z = B f / (d + doffs)
//   baseline=...                   (mm)
//   width=, height=, ndisp=, ...   ndisp: a bound on the disparities (optional here)
#pragma once

#include <filesystem>
#include <string>

namespace linesight {

struct MiddleburyCalib {
  double focal_px = 0, cx = 0, cy = 0;  // from cam0
  double doffs_px = 0;
  double baseline_mm = 0;
  int num_disparities = 0;  // ndisp; 0 if absent
};

// Parses the text of a calib.txt; `source` names it in errors. Throws InputError naming the source
// and the field that is missing or malformed (cam0 must be a 3x3 matrix with f > 0, baseline > 0,
// ndisp a positive integer).
MiddleburyCalib ParseMiddleburyCalib(const std::string& text, const std::string& source);
// Reads and parses `path` (InputError when it cannot be read).
MiddleburyCalib ReadMiddleburyCalib(const std::filesystem::path& path);

}  // namespace linesight
