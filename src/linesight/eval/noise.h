// Image noise for robustness studies (`eval stereo --noise`), defined as MATLAB's imnoise on
// intensities scaled to [0, 1], so that figures compare with the published studies that use it.
#pragma once

#include <cstdint>
#include <string>

#include <opencv2/core.hpp>

namespace linesight {

struct NoiseSpec {
  enum class Kind { kNone, kGaussian, kSaltPepper };
  Kind kind = Kind::kNone;
  // kGaussian: variance of zero-mean noise on [0, 1] intensities (result clipped to [0, 1]).
  // kSaltPepper: fraction of samples replaced, half by 0 and half by 1.
  double amount = 0;

  // "clean" | "gauss:VARIANCE" | "sp:DENSITY" (e.g. "gauss:0.1", "sp:0.15"). Throws UsageError
  // otherwise.
  static NoiseSpec Parse(const std::string& text);
  // Inverse of Parse.
  std::string Label() const;
};

// Returns `image` (8-bit, any channel count) with noise added independently to every sample, drawn
// from a generator seeded by `seed` (deterministic).
cv::Mat AddImageNoise(const cv::Mat& image, const NoiseSpec& noise, uint64_t seed);

}  // namespace linesight
