// libFuzzer target for the base station's API request parsers: the POST bodies and the name in
// GET /api/fault/<id>.jpg (build with -DLINESIGHT_FUZZ=ON and clang, see CMakeLists.txt). Every
// input must parse or throw InputError; anything else (a crash, a sanitizer report, another
// exception, an ROI outside the image, a fault id below 1) is a finding.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "linesight/core/error.h"
#include "linesight/server/api_request.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string body(reinterpret_cast<const char*>(data), size);
  const cv::Rect image(0, 0, 752, 480);
  try {
    const linesight::RoiRequest request = linesight::ParseRoiRequest(body, image.size());
    if (request.rois) {
      for (const cv::Rect& roi : *request.rois) {
        if (roi.area() <= 0 || (roi & image) != roi) std::abort();
      }
    }
  } catch (const linesight::InputError&) {
  }
  try {
    const double d = linesight::ParseAlarmRequest(body);
    if (!(d >= 0.05 && d <= 100)) std::abort();
  } catch (const linesight::InputError&) {
  }
  try {
    (void)linesight::ParseRecordRequest(body);
  } catch (const linesight::InputError&) {
  }
  try {
    const int id = linesight::ParseFaultImageName(body);
    if (id < 1) std::abort();
  } catch (const linesight::InputError&) {
  }
  return 0;
}
