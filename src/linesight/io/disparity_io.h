// Disparity maps in the file formats of DESIGN.md. In memory a disparity map is CV_32FC1 with +inf
// invalid.
#pragma once

#include <filesystem>

#include <opencv2/core.hpp>

namespace linesight {

// KITTI uint16 PNG: value = round(d * 256), 0 = invalid. Disparities are clamped to
// [1/256, 65535/256]; non-finite ones (inf, NaN) are written as 0 = invalid. Reading throws
// InputError naming the file unless it is a 16-bit single-channel image; 0 reads as +inf.
// Round trips are bit-exact for multiples of 1/256.
cv::Mat ReadKittiDisparity(const std::filesystem::path& path);
// Writes atomically; the path must end in .png.
void WriteKittiDisparity(const std::filesystem::path& path, const cv::Mat& disparity);

// Reads a disparity map (CV_32FC1) from .pfm (grey "Pf") or KITTI .png by extension
// (case-insensitive).
cv::Mat ReadDisparity(const std::filesystem::path& path);

// Colour map for people (turbo, near = warm), invalid pixels black. The range [min_d, max_d] is
// used as is when max_d > min_d, otherwise taken from the valid values of the map.
cv::Mat ColorizeDisparity(const cv::Mat& disparity, float min_d = 0, float max_d = 0);
// Same, with a legend appended at the bottom (same width): a colour bar over the range, tick
// labels in pixels at 1-2-5 steps, and "[px]" at the right end when there is room.
cv::Mat ColorizeDisparityWithLegend(const cv::Mat& disparity, float min_d = 0, float max_d = 0);

// Error map for people: |d - gt| colour coded (0 = dark blue ... >= max_error = red), pixels
// without ground truth black, pixels without an estimate white.
cv::Mat ColorizeDisparityError(const cv::Mat& disparity, const cv::Mat& ground_truth,
                               float max_error = 4);

}  // namespace linesight
