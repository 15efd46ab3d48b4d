// libFuzzer target for the PFM decoder (build with -DLINESIGHT_FUZZ=ON and clang, see
// CMakeLists.txt). Every input must either decode or throw InputError; anything else (a crash, a
// sanitizer report, another exception type, an inconsistent result) is a finding.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "linesight/core/error.h"
#include "linesight/io/pfm.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  try {
    const cv::Mat image = linesight::DecodePfm(bytes, "fuzz.pfm");
    if (image.empty() || image.depth() != CV_32F || image.total() * image.elemSize() > size)
      std::abort();
    // A decoded image must survive a re-encode / decode round trip unchanged in shape.
    const cv::Mat again = linesight::DecodePfm(linesight::EncodePfm(image), "again.pfm");
    if (again.size() != image.size() || again.type() != image.type()) std::abort();
  } catch (const linesight::InputError&) {
  }
  return 0;
}
