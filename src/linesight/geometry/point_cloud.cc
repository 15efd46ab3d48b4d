#include "linesight/geometry/point_cloud.h"

#include <bit>
#include <cmath>
#include <cstring>
#include <sstream>

#include <fmt/format.h>

#include "linesight/core/atomic_file.h"
#include "linesight/core/error.h"
#include "linesight/geometry/depth.h"

namespace linesight {

static_assert(std::endian::native == std::endian::little,
              "PLY writer assumes a little-endian host");

void CloudOptions::Check() const {
  CheckOption(min_depth_m >= 0.0, "CloudOptions.min_depth_m", min_depth_m, "must be >= 0");
  CheckOption(max_depth_m >= 0.0, "CloudOptions.max_depth_m", max_depth_m,
              "must be >= 0 (0 = no limit)");
  CheckOption(max_depth_m == 0.0 || max_depth_m > min_depth_m, "CloudOptions.max_depth_m",
              max_depth_m, "must exceed min_depth_m");
  CheckOption(stride >= 1, "CloudOptions.stride", stride, "must be >= 1");
}

PointCloud MakePointCloud(const cv::Mat& disparity, const StereoCalibration& calib,
                          const cv::Mat& color, const CloudOptions& options) {
  options.Check();
  CheckDisparityMap(disparity, "disparity");
  GeometryFromCalibration(calib);  // validates Q
  if (!color.empty()) {
    if (color.size() != disparity.size()) {
      throw InputError(fmt::format("colour image is {}x{} but the disparity is {}x{}", color.cols,
                                   color.rows, disparity.cols, disparity.rows));
    }
    if (color.depth() != CV_8U || (color.channels() != 1 && color.channels() != 3)) {
      throw InputError("colour image must be 8-bit grey or BGR");
    }
  }
  const cv::Mat points = PointsFromDisparity(disparity, calib.Q);
  PointCloud cloud;
  for (int y = 0; y < points.rows; y += options.stride) {
    const cv::Vec3f* p = points.ptr<cv::Vec3f>(y);
    for (int x = 0; x < points.cols; x += options.stride) {
      const float z = p[x][2];
      if (!std::isfinite(z) || z <= 0.0f) continue;
      if (z < options.min_depth_m) continue;
      if (options.max_depth_m > 0.0 && z > options.max_depth_m) continue;
      cloud.points.emplace_back(p[x][0], p[x][1], z);
      if (!color.empty()) {
        if (color.channels() == 1) {
          const uchar g = color.at<uchar>(y, x);
          cloud.colors.emplace_back(g, g, g);
        } else {
          const cv::Vec3b bgr = color.at<cv::Vec3b>(y, x);
          cloud.colors.emplace_back(bgr[2], bgr[1], bgr[0]);
        }
      }
    }
  }
  return cloud;
}

std::string EncodePly(const PointCloud& cloud, PlyFormat format) {
  LS_CHECK(cloud.colors.empty() || cloud.colors.size() == cloud.points.size());
  const bool coloured = !cloud.colors.empty();
  std::string out = fmt::format(
      "ply\nformat {} 1.0\ncomment linesight point cloud: metres, left rectified camera frame\n"
      "element vertex {}\nproperty float x\nproperty float y\nproperty float z\n",
      format == PlyFormat::kAscii ? "ascii" : "binary_little_endian", cloud.points.size());
  if (coloured) out += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  out += "end_header\n";
  if (format == PlyFormat::kAscii) {
    for (size_t i = 0; i < cloud.points.size(); ++i) {
      const cv::Point3f& p = cloud.points[i];
      out += fmt::format("{} {} {}", p.x, p.y, p.z);  // shortest round-trip representation
      if (coloured) {
        out += fmt::format(" {} {} {}", cloud.colors[i][0], cloud.colors[i][1], cloud.colors[i][2]);
      }
      out += '\n';
    }
  } else {
    const size_t record = 3 * sizeof(float) + (coloured ? 3 : 0);
    const size_t header = out.size();
    out.resize(header + record * cloud.points.size());
    char* dst = out.data() + header;
    for (size_t i = 0; i < cloud.points.size(); ++i) {
      const float xyz[3] = {cloud.points[i].x, cloud.points[i].y, cloud.points[i].z};
      std::memcpy(dst, xyz, sizeof(xyz));
      dst += sizeof(xyz);
      if (coloured) {
        std::memcpy(dst, cloud.colors[i].val, 3);
        dst += 3;
      }
    }
  }
  return out;
}

void WritePly(const std::filesystem::path& path, const PointCloud& cloud, PlyFormat format) {
  WriteTextAtomic(path, EncodePly(cloud, format));
}

namespace {

int PlyTypeSize(const std::string& type) {
  if (type == "char" || type == "uchar" || type == "int8" || type == "uint8") return 1;
  if (type == "short" || type == "ushort" || type == "int16" || type == "uint16") return 2;
  if (type == "int" || type == "uint" || type == "float" || type == "int32" || type == "uint32" ||
      type == "float32") {
    return 4;
  }
  if (type == "double" || type == "float64") return 8;
  return 0;
}

struct PlyProperty {
  std::string type, name;
  size_t offset = 0;
};

}  // namespace

PointCloud DecodePly(const std::string& bytes, const std::string& name) {
  auto fail = [&](const std::string& what) {
    return InputError(fmt::format("{}: {}", name, what));
  };
  const size_t end = bytes.find("end_header\n");
  if (bytes.rfind("ply\n", 0) != 0 || end == std::string::npos) {
    throw fail("not a PLY file (expected 'ply' ... 'end_header')");
  }
  std::istringstream header(bytes.substr(0, end));
  std::string line, format;
  size_t vertex_count = 0;
  bool in_vertex = false, seen_vertex = false;
  std::vector<PlyProperty> properties;
  size_t record = 0;
  while (std::getline(header, line)) {
    std::istringstream words(line);
    std::string keyword;
    words >> keyword;
    if (keyword == "format") {
      words >> format;
    } else if (keyword == "element") {
      std::string element;
      words >> element;
      if (seen_vertex) break;  // elements after the vertices are not needed
      in_vertex = element == "vertex";
      if (!in_vertex)
        throw fail(fmt::format("element '{}' before 'vertex' is not supported", element));
      if (!(words >> vertex_count)) throw fail("bad vertex count");
      seen_vertex = true;
    } else if (keyword == "property" && in_vertex) {
      PlyProperty p;
      words >> p.type >> p.name;
      if (p.type == "list") throw fail("list properties on vertices are not supported");
      const int size = PlyTypeSize(p.type);
      if (size == 0) throw fail(fmt::format("unknown property type '{}'", p.type));
      p.offset = record;
      record += size_t(size);
      properties.push_back(p);
    }
  }
  if (format != "ascii" && format != "binary_little_endian") {
    throw fail(fmt::format("format '{}' is not supported (ascii or binary_little_endian)", format));
  }
  auto find = [&](const char* prop) -> const PlyProperty* {
    for (const PlyProperty& p : properties) {
      if (p.name == prop) return &p;
    }
    return nullptr;
  };
  const PlyProperty *px = find("x"), *py = find("y"), *pz = find("z");
  if (!px || !py || !pz || px->type != "float" || py->type != "float" || pz->type != "float") {
    throw fail("vertex needs float properties x, y, z");
  }
  const PlyProperty *pr = find("red"), *pg = find("green"), *pb = find("blue");
  const bool coloured = pr && pg && pb;
  PointCloud cloud;
  cloud.points.reserve(vertex_count);
  const size_t body = end + std::strlen("end_header\n");
  if (format == "binary_little_endian") {
    if (bytes.size() < body + record * vertex_count) {
      throw fail(
          fmt::format("truncated: {} vertices of {} bytes need {} bytes after the header, found {}",
                      vertex_count, record, record * vertex_count, bytes.size() - body));
    }
    for (size_t i = 0; i < vertex_count; ++i) {
      const char* r = bytes.data() + body + i * record;
      float x, y, z;
      std::memcpy(&x, r + px->offset, 4);
      std::memcpy(&y, r + py->offset, 4);
      std::memcpy(&z, r + pz->offset, 4);
      cloud.points.emplace_back(x, y, z);
      if (coloured) {
        cloud.colors.emplace_back(uchar(r[pr->offset]), uchar(r[pg->offset]), uchar(r[pb->offset]));
      }
    }
  } else {
    std::istringstream text(bytes.substr(body));
    std::vector<double> values(properties.size());
    for (size_t i = 0; i < vertex_count; ++i) {
      for (double& v : values) {
        if (!(text >> v)) throw fail(fmt::format("vertex {} is incomplete", i));
      }
      auto at = [&](const PlyProperty* p) { return values[size_t(p - properties.data())]; };
      cloud.points.emplace_back(float(at(px)), float(at(py)), float(at(pz)));
      if (coloured) cloud.colors.emplace_back(uchar(at(pr)), uchar(at(pg)), uchar(at(pb)));
    }
  }
  return cloud;
}

PointCloud ReadPly(const std::filesystem::path& path) {
  return DecodePly(ReadTextFile(path), path.string());
}

}  // namespace linesight
