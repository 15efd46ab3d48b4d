#include "linesight/server/api_request.h"

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "linesight/core/error.h"

namespace linesight {

namespace {

nlohmann::json ParseObject(const std::string& body, const char* expected) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(body);
  } catch (const nlohmann::json::exception&) {
    throw InputError("the request body is not valid JSON");
  }
  if (!j.is_object()) throw InputError(fmt::format("expected a JSON object {}", expected));
  return j;
}

}  // namespace

double ParseAlarmRequest(const std::string& body) {
  const nlohmann::json j = ParseObject(body, "{\"distance_m\": number}");
  for (const auto& [key, value] : j.items()) {
    if (key != "distance_m") {
      throw InputError(fmt::format("unknown field '{}' (expected 'distance_m')", key));
    }
  }
  if (!j.contains("distance_m") || !j["distance_m"].is_number()) {
    throw InputError("'distance_m' must be a number (m along the line)");
  }
  const double d = j["distance_m"].get<double>();
  if (!(d >= 0.05 && d <= 100)) {
    throw InputError(fmt::format("'distance_m' = {} must be in [0.05, 100] m", d));
  }
  return d;
}

bool ParseRecordRequest(const std::string& body) {
  const nlohmann::json j = ParseObject(body, "{\"on\": bool}");
  for (const auto& [key, value] : j.items()) {
    if (key != "on") throw InputError(fmt::format("unknown field '{}' (expected 'on')", key));
  }
  if (!j.contains("on") || !j["on"].is_boolean()) {
    throw InputError("'on' must be true (start a new recording) or false (stop it)");
  }
  return j["on"].get<bool>();
}

int ParseFaultImageName(const std::string& name) {
  constexpr std::string_view kSuffix = ".jpg";
  const std::string_view text(name);
  const auto refuse = [&] {
    // The name is echoed back shortened: the answer stays small whatever the URL holds.
    const std::string shown = name.size() > 40 ? name.substr(0, 40) + "..." : name;
    return InputError(fmt::format(
        "'{}' is not a fault crop: expected <id>.jpg with the id (1, 2, ...) of a fault in the "
        "result's line.inspection.faults",
        shown));
  };
  if (text.size() <= kSuffix.size() || text.substr(text.size() - kSuffix.size()) != kSuffix) {
    throw refuse();
  }
  const std::string_view digits = text.substr(0, text.size() - kSuffix.size());
  if (digits.size() > 9 || digits.front() == '0' ||
      !std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; })) {
    throw refuse();
  }
  return std::stoi(std::string(digits));
}

RoiRequest ParseRoiRequest(const std::string& body, cv::Size image) {
  nlohmann::json j = ParseObject(body, "{\"rois\": [...], \"auto\": bool}");
  RoiRequest request;
  for (const auto& [key, value] : j.items()) {
    if (key != "rois" && key != "auto") {
      throw InputError(fmt::format("unknown field '{}' (expected 'rois' and/or 'auto')", key));
    }
  }
  if (j.contains("auto")) {
    if (!j["auto"].is_boolean()) throw InputError("'auto' must be true or false");
    request.auto_detect = j["auto"].get<bool>();
  }
  if (j.contains("rois")) {
    const nlohmann::json& rois = j["rois"];
    if (!rois.is_array()) throw InputError("'rois' must be an array of [x, y, w, h]");
    constexpr size_t kMaxRois = 32;
    if (rois.size() > kMaxRois) {
      throw InputError(fmt::format("at most {} ROIs, got {}", kMaxRois, rois.size()));
    }
    std::vector<cv::Rect> out;
    for (size_t i = 0; i < rois.size(); ++i) {
      const nlohmann::json& r = rois[i];
      const bool shape_ok = r.is_array() && r.size() == 4 &&
                            std::all_of(r.begin(), r.end(), [](const nlohmann::json& v) {
                              constexpr int64_t kLimit = 1'000'000;  // far beyond any image
                              if (v.is_number_unsigned()) return v.get<uint64_t>() <= kLimit;
                              return v.is_number_integer() && v.get<int64_t>() >= -kLimit &&
                                     v.get<int64_t>() <= kLimit;
                            });
      if (!shape_ok) {
        throw InputError(fmt::format("rois[{}]: expected [x, y, w, h] of integers", i));
      }
      const cv::Rect rect(r[0].get<int>(), r[1].get<int>(), r[2].get<int>(), r[3].get<int>());
      if (rect.width <= 0 || rect.height <= 0 || rect.x < 0 || rect.y < 0 ||
          rect.x + rect.width > image.width || rect.y + rect.height > image.height) {
        throw InputError(fmt::format("rois[{}] = {},{},{},{} is not inside the {}x{} image", i,
                                     rect.x, rect.y, rect.width, rect.height, image.width,
                                     image.height));
      }
      out.push_back(rect);
    }
    request.rois = std::move(out);
  }
  return request;
}

}  // namespace linesight
