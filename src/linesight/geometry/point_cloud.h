// Point clouds from disparity and PLY files (binary little-endian by default, ASCII on request)
// with x y z in metres (float) and optional red green blue (uchar), readable by MeshLab and Open3D.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "linesight/io/stereo_calibration.h"

namespace linesight {

struct PointCloud {
  std::vector<cv::Point3f> points;  // metres, left rectified camera frame
  std::vector<cv::Vec3b> colors;    // RGB per point, or empty for an uncoloured cloud
};

struct CloudOptions {
  double min_depth_m = 0.0;  // points nearer than this (m) are dropped; 0 keeps all
  double max_depth_m = 0.0;  // points farther than this (m) are dropped; 0 keeps all
  int stride = 1;            // keep every stride-th pixel in x and y (1 = every pixel)

  void Check() const;
};

// One point per valid disparity pixel through Q. `color` (optional, same size, 8-bit grey or BGR)
// colours the points. Throws InputError when the disparity holds NaN/-inf or the colour image has
// another size.
PointCloud MakePointCloud(const cv::Mat& disparity, const StereoCalibration& calib,
                          const cv::Mat& color, const CloudOptions& options);

enum class PlyFormat { kBinaryLittleEndian, kAscii };

// The whole file as bytes.
std::string EncodePly(const PointCloud& cloud, PlyFormat format);
// Written atomically.
void WritePly(const std::filesystem::path& path, const PointCloud& cloud,
              PlyFormat format = PlyFormat::kBinaryLittleEndian);

// Reads a PLY with a vertex element holding float x y z and optionally uchar red green blue (ascii
// or binary_little_endian; other vertex properties of fixed size are skipped). Throws InputError
// naming the file.
PointCloud ReadPly(const std::filesystem::path& path);
PointCloud DecodePly(const std::string& bytes, const std::string& name);

}  // namespace linesight
