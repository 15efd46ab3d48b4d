// PNG and JPEG through libpng and libjpeg-turbo directly.
//
// OpenCV's imgcodecs module decodes the same formats with the same libraries, but Debian builds it
// with GDAL, whose ~120 shared libraries take ~100 ms to load in every process that links it. These
// codecs give the pixels cv::imdecode gives (the same libpng / libjpeg transformations in the same
// order: libpng's own RGB-to-grey conversion, 16-to-8-bit stripping, palette expansion, libjpeg's
// own colour conversion), which image_codecs_test checks on every image format variant it builds.
// Whatever they do not reproduce exactly (CMYK or EXIF-oriented JPEGs, animated or EXIF PNGs, other
// formats) they decline, and the caller falls back to OpenCV (io/opencv_plugin.h).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include <opencv2/core.hpp>

namespace linesight::detail {

enum class DecodeStatus {
  kDecoded,     // `image` holds what cv::imdecode(bytes, flags) returns
  kCorrupt,     // a PNG or JPEG that cannot be decoded (cv::imdecode returns an empty image too)
  kNotHandled,  // another format, or a variant decoded by OpenCV only
};

// `flags`: cv::IMREAD_GRAYSCALE, cv::IMREAD_COLOR or cv::IMREAD_UNCHANGED.
DecodeStatus DecodePngOrJpeg(std::span<const uint8_t> bytes, int flags, cv::Mat* image);

// PNG of an 8- or 16-bit image with 1, 3 (BGR) or 4 (BGRA) channels; false for other types.
bool EncodePng(const cv::Mat& image, std::vector<uint8_t>* bytes);

// Baseline JPEG of an 8-bit grey or BGR image at `quality` (1..100); false for other types.
bool EncodeJpeg(const cv::Mat& image, int quality, std::vector<uint8_t>* bytes);

}  // namespace linesight::detail
