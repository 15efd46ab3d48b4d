// Requests of the base station's JSON API (base_station.h), parsed from untrusted HTTP bodies.
// Fuzzed: api_request_fuzz.cc (libFuzzer) and a seeded mutation test in base_station_test.cc.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace linesight {

// What the API's POST /api/rois carries. ParseRoiRequest throws InputError with a message fit for
// the HTTP answer ("rois[1]: expected [x, y, w, h] of integers") for anything but a JSON object
// with an optional "rois" array of 4-integer arrays inside `image` and an optional boolean "auto".
struct RoiRequest {
  std::optional<std::vector<cv::Rect>> rois;
  std::optional<bool> auto_detect;
};
RoiRequest ParseRoiRequest(const std::string& body, cv::Size image);

// What POST /api/alarm carries: {"distance_m": x} with 0.05 <= x <= 100. InputError otherwise.
double ParseAlarmRequest(const std::string& body);

// What POST /api/record carries: {"on": true|false}. InputError otherwise.
bool ParseRecordRequest(const std::string& body);

// The last part of GET /api/fault/<id>.jpg: "<id>.jpg" with a positive decimal id (no sign, no
// leading zero, at most 9 digits). InputError naming what was expected otherwise.
int ParseFaultImageName(const std::string& name);

}  // namespace linesight
