#include "linesight/io/middlebury_calib.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>
#include <sstream>
#include <vector>

#include <fmt/format.h>

#include "linesight/core/atomic_file.h"
#include "linesight/core/error.h"

namespace linesight {

namespace {

double ParseCalibNumber(const std::string& source, const std::string& key,
                        const std::string& text) {
  std::istringstream in(text);
  double value = 0;
  if (!(in >> value) || !std::isfinite(value)) {
    throw InputError(fmt::format("{}: '{}={}' is not a number", source, key, text));
  }
  return value;
}

}  // namespace

MiddleburyCalib ParseMiddleburyCalib(const std::string& text, const std::string& source) {
  std::istringstream in(text);
  std::map<std::string, std::string> values;
  for (std::string line; std::getline(in, line);) {
    const auto eq = line.find('=');
    if (eq == std::string::npos) continue;
    std::string key = line.substr(0, eq);
    key.erase(
        std::remove_if(key.begin(), key.end(), [](unsigned char c) { return std::isspace(c); }),
        key.end());
    values[key] = line.substr(eq + 1);
  }
  auto require = [&](const char* key) -> const std::string& {
    const auto it = values.find(key);
    if (it == values.end()) {
      throw InputError(fmt::format(
          "{}: field '{}' is missing (expected Middlebury calib.txt layout)", source, key));
    }
    return it->second;
  };
  MiddleburyCalib calib;
  std::string cam0 = require("cam0");
  std::replace_if(
      cam0.begin(), cam0.end(), [](char c) { return c == '[' || c == ']' || c == ';'; }, ' ');
  std::istringstream cam_in(cam0);
  std::vector<double> k;
  for (double v = 0; k.size() < 9 && cam_in >> v;) k.push_back(v);
  if (k.size() != 9 ||
      !std::all_of(k.begin(), k.end(), [](double v) { return std::isfinite(v); }) || k[0] <= 0) {
    throw InputError(fmt::format(
        "{}: field 'cam0' must be a 3x3 matrix [f 0 cx; 0 f cy; 0 0 1] with f > 0", source));
  }
  calib.focal_px = k[0];
  calib.cx = k[2];
  calib.cy = k[5];
  calib.doffs_px = ParseCalibNumber(source, "doffs", require("doffs"));
  calib.baseline_mm = ParseCalibNumber(source, "baseline", require("baseline"));
  if (calib.baseline_mm <= 0) {
    throw InputError(fmt::format("{}: field 'baseline' must be positive (mm), got {}", source,
                                 calib.baseline_mm));
  }
  if (values.count("ndisp")) {
    const double ndisp = ParseCalibNumber(source, "ndisp", values["ndisp"]);
    if (ndisp < 1 || ndisp != std::floor(ndisp)) {
      throw InputError(fmt::format("{}: field 'ndisp' must be a positive integer, got {}", source,
                                   values["ndisp"]));
    }
    calib.num_disparities = static_cast<int>(ndisp);
  }
  return calib;
}

MiddleburyCalib ReadMiddleburyCalib(const std::filesystem::path& path) {
  return ParseMiddleburyCalib(ReadTextFile(path), path.string());
}

}  // namespace linesight
