#include "linesight/geometry/point_cloud.h"

#include <filesystem>

#include <gtest/gtest.h>

#include "linesight/core/atomic_file.h"
#include "linesight/core/disparity.h"
#include "linesight/core/error.h"

namespace linesight {
namespace {

constexpr double kF = 700.0, kCx = 80.0, kCy = 60.0, kB = 0.12;

StereoCalibration Rig() {
  StereoCalibration c;
  c.image_size = {160, 120};
  c.Q = (cv::Mat_<double>(4, 4) << 1, 0, 0, -kCx, 0, 1, 0, -kCy, 0, 0, 0, kF, 0, 0, 1.0 / kB, 0);
  return c;
}

// Disparity of the tilted plane Z = z0 + tx * X + ty * Y seen by Rig().
cv::Mat PlaneDisparity(double z0, double tx, double ty) {
  cv::Mat d(120, 160, CV_32F);
  for (int v = 0; v < d.rows; ++v) {
    for (int u = 0; u < d.cols; ++u) {
      const double z = z0 / (1.0 - tx * (u - kCx) / kF - ty * (v - kCy) / kF);
      d.at<float>(v, u) = float(kF * kB / z);
    }
  }
  return d;
}

TEST(CloudOptionsTest, DefaultsAreValidAndBoundsAreChecked) {
  EXPECT_NO_THROW(CloudOptions{}.Check());
  EXPECT_THROW((CloudOptions{.min_depth_m = -1.0}.Check()), OptionError);
  EXPECT_THROW((CloudOptions{.min_depth_m = 3.0, .max_depth_m = 2.0}.Check()), OptionError);
  EXPECT_THROW((CloudOptions{.stride = 0}.Check()), OptionError);
}

TEST(PointCloudTest, PlaneRoundTripThroughDisparity) {
  const double z0 = 2.0, tx = 0.3, ty = -0.2;
  cv::Mat disparity = PlaneDisparity(z0, tx, ty);
  disparity.at<float>(10, 10) = kInvalidDisparity;
  const PointCloud cloud = MakePointCloud(disparity, Rig(), cv::Mat(), {});
  ASSERT_EQ(cloud.points.size(), size_t(160 * 120 - 1));
  EXPECT_TRUE(cloud.colors.empty());
  double worst = 0.0;
  for (const cv::Point3f& p : cloud.points) {
    worst = std::max(worst, std::abs(p.z - (z0 + tx * p.x + ty * p.y)));
  }
  EXPECT_LT(worst, 1e-5);
  // Pixel (0, 0) is the first point: X = (0 - cx) Z / f.
  const cv::Point3f first = cloud.points.front();
  EXPECT_NEAR(first.x, -kCx * first.z / kF, 1e-6);
  EXPECT_NEAR(first.y, -kCy * first.z / kF, 1e-6);
}

TEST(PointCloudTest, DepthLimitsStrideAndColour) {
  const cv::Mat disparity = PlaneDisparity(2.0, 0.0, 0.0);
  cv::Mat colour(120, 160, CV_8UC3, cv::Scalar(10, 20, 30));  // BGR
  EXPECT_TRUE(MakePointCloud(disparity, Rig(), colour, {.max_depth_m = 1.9}).points.empty());
  EXPECT_TRUE(MakePointCloud(disparity, Rig(), colour, {.min_depth_m = 2.1}).points.empty());
  const PointCloud cloud = MakePointCloud(disparity, Rig(), colour, {.stride = 4});
  ASSERT_EQ(cloud.points.size(), size_t(40 * 30));
  ASSERT_EQ(cloud.colors.size(), cloud.points.size());
  EXPECT_EQ(cloud.colors[0], cv::Vec3b(30, 20, 10));  // stored as RGB
  EXPECT_THROW(MakePointCloud(disparity, Rig(), cv::Mat(10, 10, CV_8UC3), {}), InputError);
}

PointCloud SmallCloud(bool coloured) {
  PointCloud cloud;
  cloud.points = {{0.1f, -0.2f, 1.5f}, {1e-7f, 3.25f, 5.999f}, {-0.333333f, 0.0f, 0.3f}};
  if (coloured) {
    cloud.colors.push_back(cv::Vec3b(255, 0, 1));
    cloud.colors.push_back(cv::Vec3b(2, 3, 4));
    cloud.colors.push_back(cv::Vec3b(128, 129, 130));
  }
  return cloud;
}

void ExpectSameCloud(const PointCloud& a, const PointCloud& b) {
  ASSERT_EQ(a.points.size(), b.points.size());
  ASSERT_EQ(a.colors.size(), b.colors.size());
  for (size_t i = 0; i < a.points.size(); ++i) {
    EXPECT_EQ(a.points[i], b.points[i])
        << i;  // bit-exact, also for ASCII (shortest round-trip digits)
  }
  for (size_t i = 0; i < a.colors.size(); ++i) EXPECT_EQ(a.colors[i], b.colors[i]) << i;
}

TEST(PlyTest, BinaryHeaderAndSize) {
  const std::string bytes = EncodePly(SmallCloud(true), PlyFormat::kBinaryLittleEndian);
  const std::string header =
      "ply\nformat binary_little_endian 1.0\n"
      "comment linesight point cloud: metres, left rectified camera frame\n"
      "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n";
  ASSERT_EQ(bytes.substr(0, header.size()), header);
  EXPECT_EQ(bytes.size(), header.size() + 3 * 15);
  float x;
  std::memcpy(&x, bytes.data() + header.size(), 4);
  EXPECT_EQ(x, 0.1f);
  EXPECT_EQ(uchar(bytes[header.size() + 12]), 255);
  const std::string plain = EncodePly(SmallCloud(false), PlyFormat::kBinaryLittleEndian);
  EXPECT_EQ(plain.find("property uchar"), std::string::npos);
  EXPECT_EQ(plain.size(), plain.find("end_header\n") + 11 + 3 * 12);
}

TEST(PlyTest, BinaryAndAsciiParseBack) {
  for (bool coloured : {false, true}) {
    for (PlyFormat format : {PlyFormat::kBinaryLittleEndian, PlyFormat::kAscii}) {
      const auto path = std::filesystem::temp_directory_path() / "linesight_ply_test.ply";
      WritePly(path, SmallCloud(coloured), format);
      const PointCloud back = ReadPly(path);
      std::filesystem::remove(path);
      ExpectSameCloud(SmallCloud(coloured), back);
    }
  }
  EXPECT_NE(EncodePly(SmallCloud(true), PlyFormat::kAscii).find("format ascii 1.0\n"),
            std::string::npos);
}

TEST(PlyTest, RejectsMalformedFiles) {
  EXPECT_THROW(DecodePly("not a ply", "x.ply"), InputError);
  std::string bytes = EncodePly(SmallCloud(true), PlyFormat::kBinaryLittleEndian);
  bytes.resize(bytes.size() - 1);
  try {
    DecodePly(bytes, "x.ply");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("x.ply: truncated"), std::string::npos) << e.what();
  }
  EXPECT_THROW(
      DecodePly("ply\nformat binary_big_endian 1.0\nelement vertex 0\nend_header\n", "b.ply"),
      InputError);
}

}  // namespace
}  // namespace linesight
