// linesight cloud: point cloud (PLY, metres, left rectified camera frame) from a disparity map.
#include <filesystem>

#include <fmt/format.h>

#include "cli.h"
#include "commands.h"
#include "linesight/core/error.h"
#include "linesight/geometry/depth.h"
#include "linesight/geometry/point_cloud.h"
#include "linesight/io/image_io.h"
#include "linesight/io/pfm.h"
#include "linesight/io/stereo_calibration.h"

namespace linesight::cli {

int RunCloud(int argc, char** argv) {
  CLI::App app{
      "Point cloud from a rectified left disparity map: PLY (binary little-endian by default), "
      "x y z in metres in the left rectified camera frame, rgb from --left.",
      "cloud"};
  std::string calib_path, disparity_path, left_path, out_path, depth_path;
  bool ascii = false;
  CloudOptions options;
  app.add_option("--calib", calib_path, "stereo calibration (its Q maps disparity to 3D)")
      ->required();
  app.add_option("--disparity", disparity_path, "disparity PFM (float px, inf = invalid)")
      ->required();
  app.add_option("--left", left_path, "rectified left image to colour the points");
  app.add_option("--out", out_path, "output PLY")->required();
  app.add_flag("--ascii", ascii, "write ASCII PLY instead of binary");
  app.add_option("--min-depth", options.min_depth_m, "drop nearer points (m)")
      ->capture_default_str();
  app.add_option("--max-depth", options.max_depth_m, "drop farther points (m), 0 = keep all")
      ->capture_default_str();
  app.add_option("--stride", options.stride, "keep every n-th pixel in x and y")
      ->capture_default_str();
  app.add_option("--depth", depth_path,
                 "also write the depth as 16-bit PNG in millimetres (0 = none)");
  return RunCommand(app, argc, argv, [&] {
    options.Check();
    const StereoCalibration calib = ReadStereoCalibration(calib_path);
    const cv::Mat disparity = ReadPfm(disparity_path);
    if (disparity.channels() != 1)
      throw InputError(fmt::format("{}: expected a one-channel PFM", disparity_path));
    CheckDisparityMap(disparity, disparity_path);
    CheckCalibrationMatchesImage(calib, disparity.size(), calib_path);
    cv::Mat colour;
    if (!left_path.empty()) {
      colour = ReadImage(left_path, ImageColor::kColor);
      if (colour.size() != disparity.size()) {
        throw InputError(fmt::format("{} is {}x{} but {} is {}x{}", left_path, colour.cols,
                                     colour.rows, disparity_path, disparity.cols, disparity.rows));
      }
    }
    const PointCloud cloud = MakePointCloud(disparity, calib, colour, options);
    WritePly(out_path, cloud, ascii ? PlyFormat::kAscii : PlyFormat::kBinaryLittleEndian);
    if (!depth_path.empty()) {
      WriteDepthPng16(depth_path, DepthFromDisparity(disparity, GeometryFromCalibration(calib)));
    }
    std::fprintf(stderr, "%zu points -> %s (%s)\n", cloud.points.size(), out_path.c_str(),
                 ascii ? "ascii" : "binary little-endian");
  });
}

}  // namespace linesight::cli
