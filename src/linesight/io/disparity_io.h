// Disparity maps in the file formats of DESIGN.md. In memory a disparity map is CV_32FC1 with +inf
// invalid.
#pragma once

#include <filesystem>

#include <opencv2/core.hpp>

namespace linesight {

// KITTI uint16 PNG: value = round(d * 256), 0 = invalid. Disparities are clamped to [1/256,
// 65535/256].
cv::Mat ReadKittiDisparity(const std::filesystem::path& path);
void WriteKittiDisparity(const std::filesystem::path& path, const cv::Mat& disparity);

// Reads a disparity map from .pfm or KITTI .png by extension.
cv::Mat ReadDisparity(const std::filesystem::path& path);

// Colour map for people (turbo, near = warm), invalid pixels black. The range [min_d, max_d] is
// used as is when max_d > min_d, otherwise taken from the valid values of the map.
cv::Mat ColorizeDisparity(const cv::Mat& disparity, float min_d = 0, float max_d = 0);
// Same, with a colour bar legend with tick labels (in pixels) appended at the bottom.
cv::Mat ColorizeDisparityWithLegend(const cv::Mat& disparity, float min_d = 0, float max_d = 0);

// Error map for people: |d - gt| colour coded (0 = dark blue ... >= max_error = red), pixels
// without ground truth black, pixels without an estimate white.
cv::Mat ColorizeDisparityError(const cv::Mat& disparity, const cv::Mat& ground_truth,
                               float max_error = 4);

}  // namespace linesight
