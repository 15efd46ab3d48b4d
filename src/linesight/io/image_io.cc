#include "linesight/io/image_io.h"

#include <glob.h>

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <string>
#include <system_error>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>  // the IMREAD_* flag values only (an enum, nothing to link)

#include "linesight/core/atomic_file.h"
#include "linesight/core/error.h"
#include "linesight/io/image_codecs.h"
#include "linesight/io/opencv_plugin.h"

namespace linesight {
namespace fs = std::filesystem;

namespace {

constexpr const char* kExpectedImage =
    "expected an image file (PNG, JPEG, TIFF, BMP, PNM, WebP, ...)";

// PNG colour type 3 = indexed colour. The IHDR chunk is always first: 8-byte signature, 4-byte
// length, "IHDR", width (4), height (4), bit depth (1), colour type (1) -> colour type at byte
// offset 25.
bool IsPalettePng(const std::string& bytes) {
  static constexpr unsigned char kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (bytes.size() < 26) return false;
  for (int i = 0; i < 8; ++i) {
    if (static_cast<unsigned char>(bytes[i]) != kSignature[i]) return false;
  }
  return bytes.compare(12, 4, "IHDR") == 0 && static_cast<unsigned char>(bytes[25]) == 3;
}

int ImreadFlags(ImageColor color, bool palette) {
  switch (color) {
    case ImageColor::kGray:
      return cv::IMREAD_GRAYSCALE;
    case ImageColor::kColor:
      return cv::IMREAD_COLOR;
    case ImageColor::kUnchanged:
      // IMREAD_UNCHANGED expands a palette to BGR(A); IMREAD_GRAYSCALE maps it through the palette
      // to grey values (exact for grey palettes such as Middlebury's ground truths and masks).
      return palette ? cv::IMREAD_GRAYSCALE : cv::IMREAD_UNCHANGED;
  }
  return cv::IMREAD_UNCHANGED;
}

}  // namespace

cv::Mat ReadImage(const fs::path& path, ImageColor color) {
  std::error_code ec;
  if (!fs::exists(path, ec)) {
    throw InputError(
        fmt::format("{}: cannot read image: no such file ({})", path.string(), kExpectedImage));
  }
  if (fs::is_directory(path, ec)) {
    throw InputError(
        fmt::format("{}: cannot read image: this is a folder ({})", path.string(), kExpectedImage));
  }
  const std::string bytes = ReadTextFile(path);
  if (bytes.empty()) {
    throw InputError(fmt::format("{}: cannot read image: the file is empty ({})", path.string(),
                                 kExpectedImage));
  }
  const int flags = ImreadFlags(color, IsPalettePng(bytes));
  const auto* data = reinterpret_cast<const uint8_t*>(bytes.data());
  cv::Mat image;
  if (detail::DecodePngOrJpeg({data, bytes.size()}, flags, &image) ==
      detail::DecodeStatus::kNotHandled) {
    const cv::Mat buffer(1, static_cast<int>(bytes.size()), CV_8UC1,
                         const_cast<char*>(bytes.data()));
    try {
      image = LoadOpenCvPlugin(fmt::format("reading {}", path.string())).Decode(buffer, flags);
    } catch (const cv::Exception& e) {
      throw InputError(
          fmt::format("{}: cannot decode image: {} ({})", path.string(), e.err, kExpectedImage));
    }
  }
  if (image.empty()) {
    throw InputError(fmt::format("{}: cannot decode image: unknown format or corrupt data ({})",
                                 path.string(), kExpectedImage));
  }
  return image;
}

void WriteImage(const fs::path& path, const cv::Mat& image) {
  if (image.empty())
    throw InputError(fmt::format("{}: cannot write an empty image", path.string()));
  std::string extension = path.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  // PNG and JPEG (OpenCV's default quality, 95) without loading imgcodecs.
  std::vector<uint8_t> bytes;
  const bool encoded =
      (extension == ".png" && detail::EncodePng(image, &bytes)) ||
      ((extension == ".jpg" || extension == ".jpeg") && detail::EncodeJpeg(image, 95, &bytes));
  if (encoded) {
    WriteTextAtomic(path,
                    std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
    return;
  }
  WriteFileAtomic(path, [&](const fs::path& tmp) {
    bool ok = false;
    try {
      ok = LoadOpenCvPlugin(fmt::format("writing {}", path.string())).Write(tmp.string(), image);
    } catch (const cv::Exception& e) {
      throw InputError(fmt::format("{}: cannot write image ({}x{}, {} channel(s), depth {}): {}",
                                   path.string(), image.cols, image.rows, image.channels(),
                                   image.depth(), e.err));
    }
    if (!ok) {
      throw InputError(
          fmt::format("{}: cannot write image (unsupported extension '{}' or write failed)",
                      path.string(), path.extension().string()));
    }
  });
}

void CheckSameSize(const cv::Mat& left, const fs::path& left_path, const cv::Mat& right,
                   const fs::path& right_path) {
  if (left.size() != right.size()) {
    throw InputError(fmt::format(
        "{} is {}x{} but {} is {}x{}: the two images must have the same size", left_path.string(),
        left.cols, left.rows, right_path.string(), right.cols, right.rows));
  }
}

std::vector<std::filesystem::path> ExpandGlob(const std::string& pattern) {
  glob_t result{};
  const int status = ::glob(pattern.c_str(), 0, nullptr, &result);
  std::vector<std::filesystem::path> paths;
  if (status == 0) {
    for (size_t i = 0; i < result.gl_pathc; ++i) paths.emplace_back(result.gl_pathv[i]);
  }
  globfree(&result);
  if (paths.empty()) throw InputError(fmt::format("'{}' matches no file", pattern));
  std::sort(paths.begin(), paths.end());
  return paths;
}

}  // namespace linesight
