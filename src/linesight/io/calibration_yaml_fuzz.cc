// libFuzzer target for the stereo calibration parser (OpenCV FileStorage YAML/XML/JSON from
// memory). Every input must either decode or throw InputError; anything else is a finding.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "linesight/core/error.h"
#include "linesight/io/stereo_calibration.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const linesight::StereoCalibration calib = linesight::DecodeStereoCalibration(text, "fuzz.yml");
    if (calib.M1.size() != cv::Size(3, 3) || calib.Q.size() != cv::Size(4, 4) ||
        calib.image_size.width <= 0) {
      std::abort();
    }
    // What we decoded we must be able to write and read back.
    const linesight::StereoCalibration again =
        linesight::DecodeStereoCalibration(linesight::EncodeStereoCalibration(calib), "again.yml");
    if (again.image_size != calib.image_size) std::abort();
  } catch (const linesight::InputError&) {
  }
  return 0;
}
