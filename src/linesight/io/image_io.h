// Image reading and writing with errors that name the file.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace linesight {

enum class ImageColor {
  kGray,       // 8-bit single channel; palette PNGs are mapped through their palette to grey values
  kColor,      // 8-bit BGR
  kUnchanged,  // as stored (8/16-bit, 1/3/4 channels), except that palette images become grey
               // values
};

// Reads an image. Throws InputError naming the file when it is missing, empty or not a decodable
// image.
cv::Mat ReadImage(const std::filesystem::path& path, ImageColor color);

// Writes an image (format from the extension) atomically. Throws InputError naming the file on
// failure.
void WriteImage(const std::filesystem::path& path, const cv::Mat& image);

// Throws InputError unless both images have the same size ("left.png is 640x480 but right.png is
// 320x240").
void CheckSameSize(const cv::Mat& left, const std::filesystem::path& left_path,
                   const cv::Mat& right, const std::filesystem::path& right_path);

// Expands a glob (`*`, `?` and `[...]` in the file name part) into sorted paths; throws InputError
// when nothing matches.
std::vector<std::filesystem::path> ExpandGlob(const std::string& pattern);

}  // namespace linesight
