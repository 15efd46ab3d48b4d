#include "linesight/eval/noise.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <random>

#include <fmt/format.h>

#include "linesight/core/error.h"

namespace linesight {

NoiseSpec NoiseSpec::Parse(const std::string& text) {
  if (text == "clean" || text == "none") return {};
  const auto colon = text.find(':');
  const std::string kind = text.substr(0, colon);
  double amount = -1;
  if (colon != std::string::npos) {
    const char* begin = text.data() + colon + 1;
    const char* end = text.data() + text.size();
    auto [ptr, ec] = std::from_chars(begin, end, amount);
    if (ec != std::errc() || ptr != end) amount = -1;
  }
  if (kind == "gauss" && amount > 0 && amount <= 1) return {Kind::kGaussian, amount};
  if (kind == "sp" && amount > 0 && amount <= 1) return {Kind::kSaltPepper, amount};
  throw UsageError(fmt::format(
      "noise '{}': expected clean, gauss:VARIANCE or sp:DENSITY with a value in (0, 1]", text));
}

std::string NoiseSpec::Label() const {
  switch (kind) {
    case Kind::kGaussian:
      return fmt::format("gauss:{:g}", amount);
    case Kind::kSaltPepper:
      return fmt::format("sp:{:g}", amount);
    case Kind::kNone:
      break;
  }
  return "clean";
}

cv::Mat AddImageNoise(const cv::Mat& image, const NoiseSpec& noise, uint64_t seed) {
  LS_CHECK(image.depth() == CV_8U);
  cv::Mat out = image.clone();
  if (noise.kind == NoiseSpec::Kind::kNone) return out;
  std::mt19937_64 rng(seed);
  const int samples_per_row = out.cols * out.channels();
  if (noise.kind == NoiseSpec::Kind::kGaussian) {
    std::normal_distribution<double> gauss(0.0, std::sqrt(noise.amount));
    for (int y = 0; y < out.rows; ++y) {
      uint8_t* row = out.ptr<uint8_t>(y);
      for (int i = 0; i < samples_per_row; ++i) {
        const double v = std::clamp(row[i] / 255.0 + gauss(rng), 0.0, 1.0);
        row[i] = static_cast<uint8_t>(std::lround(v * 255.0));
      }
    }
  } else {
    std::uniform_real_distribution<double> uniform(0.0, 1.0);
    for (int y = 0; y < out.rows; ++y) {
      uint8_t* row = out.ptr<uint8_t>(y);
      for (int i = 0; i < samples_per_row; ++i) {
        const double u = uniform(rng);
        if (u < noise.amount / 2) {
          row[i] = 0;
        } else if (u < noise.amount) {
          row[i] = 255;
        }
      }
    }
  }
  return out;
}

}  // namespace linesight
