#include "linesight/io/stereo_calibration.h"

#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/persistence.hpp>

#include "linesight/core/atomic_file.h"
#include "linesight/io/io_test_util.h"

namespace linesight {
namespace {
namespace fs = std::filesystem;
using testing::ExpectInputError;

class StereoCalibrationTest : public testing::TempDirTest {};

const std::vector<std::string> kMatrixFields = {"M1", "D1", "M2", "D2", "R",  "T", "E",
                                                "F",  "R1", "R2", "P1", "P2", "Q"};

// A realistic rig: 640x480, f = 700 px, baseline 0.12 m, slight rotation, rectified by OpenCV.
StereoCalibration MakeCalibration() {
  StereoCalibration c;
  c.image_size = cv::Size(640, 480);
  c.M1 = (cv::Mat_<double>(3, 3) << 700.5, 0, 321.25, 0, 701.0, 239.75, 0, 0, 1);
  c.M2 = (cv::Mat_<double>(3, 3) << 698.0, 0, 318.5, 0, 699.5, 241.0, 0, 0, 1);
  c.D1 = (cv::Mat_<double>(1, 5) << -0.21, 0.05, 0.001, -0.0005, 0.0123456789012345);
  c.D2 = (cv::Mat_<double>(1, 5) << -0.19, 0.04, -0.002, 0.0007, 0.0);
  cv::Rodrigues(cv::Vec3d(0.01, -0.02, 0.005), c.R);
  c.T = (cv::Mat_<double>(3, 1) << -0.12, 0.001, -0.002);
  const cv::Mat t_cross =
      (cv::Mat_<double>(3, 3) << 0, -c.T.at<double>(2), c.T.at<double>(1), c.T.at<double>(2), 0,
       -c.T.at<double>(0), -c.T.at<double>(1), c.T.at<double>(0), 0);
  c.E = t_cross * c.R;
  c.F = c.M2.inv().t() * c.E * c.M1.inv();
  cv::stereoRectify(c.M1, c.D1, c.M2, c.D2, c.image_size, c.R, c.T, c.R1, c.R2, c.P1, c.P2, c.Q,
                    cv::CALIB_ZERO_DISPARITY, 0);
  return c;
}

const cv::Mat& Field(const StereoCalibration& c, const std::string& key) {
  static const cv::Mat none;
  const std::pair<const char*, const cv::Mat*> fields[] = {
      {"M1", &c.M1}, {"D1", &c.D1}, {"M2", &c.M2}, {"D2", &c.D2}, {"R", &c.R},
      {"T", &c.T},   {"E", &c.E},   {"F", &c.F},   {"R1", &c.R1}, {"R2", &c.R2},
      {"P1", &c.P1}, {"P2", &c.P2}, {"Q", &c.Q}};
  for (const auto& [name, mat] : fields) {
    if (key == name) return *mat;
  }
  return none;
}

// YAML written by plain cv::FileStorage, the way OpenCV's stereo_calib sample does, leaving out
// `skip`.
std::string PlainOpenCvYaml(const StereoCalibration& c, const std::string& skip = "") {
  cv::FileStorage fs(".yml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY);
  if (skip != "image_width") fs << "image_width" << c.image_size.width;
  if (skip != "image_height") fs << "image_height" << c.image_size.height;
  for (const std::string& key : kMatrixFields) {
    if (key != skip) fs << key << Field(c, key);
  }
  return fs.releaseAndGetString();
}

void ExpectSameCalibration(const StereoCalibration& a, const StereoCalibration& b) {
  EXPECT_EQ(a.image_size, b.image_size);
  for (const std::string& key : kMatrixFields) {
    SCOPED_TRACE(key);
    const cv::Mat& ma = Field(a, key);
    const cv::Mat& mb = Field(b, key);
    ASSERT_EQ(ma.type(), CV_64FC1);
    ASSERT_EQ(ma.size(), mb.size());
    EXPECT_EQ(cv::norm(ma, mb, cv::NORM_INF), 0);  // %.16e in the YAML is exact for doubles
  }
}

TEST_F(StereoCalibrationTest, WriteReadRoundTripIsExact) {
  const StereoCalibration c = MakeCalibration();
  WriteStereoCalibration(dir_ / "stereo.yml", c);
  ExpectSameCalibration(ReadStereoCalibration(dir_ / "stereo.yml"), c);
  EXPECT_EQ(Files(), std::vector<std::string>{"stereo.yml"});
  // Whatever the extension, the content is YAML.
  WriteStereoCalibration(dir_ / "stereo.txt", c);
  EXPECT_EQ(ReadTextFile(dir_ / "stereo.txt").rfind("%YAML", 0), 0u);
  ExpectSameCalibration(ReadStereoCalibration(dir_ / "stereo.txt"), c);
}

TEST_F(StereoCalibrationTest, WrittenFileIsReadableByPlainFileStorage) {
  const StereoCalibration c = MakeCalibration();
  WriteStereoCalibration(dir_ / "stereo.yml", c);
  const std::string text = ReadTextFile(dir_ / "stereo.yml");
  EXPECT_NE(text.find("M1: !!opencv-matrix"), std::string::npos) << text;
  EXPECT_NE(text.find("image_width: 640"), std::string::npos) << text;
  cv::FileStorage fs((dir_ / "stereo.yml").string(), cv::FileStorage::READ);
  ASSERT_TRUE(fs.isOpened());
  EXPECT_EQ(static_cast<int>(fs["image_width"]), 640);
  EXPECT_EQ(static_cast<int>(fs["image_height"]), 480);
  EXPECT_TRUE(fs["image_width"].isInt());
  for (const std::string& key : kMatrixFields) {
    cv::Mat m;
    fs[key] >> m;
    EXPECT_EQ(cv::norm(m, Field(c, key), cv::NORM_INF), 0) << key;
  }
}

TEST_F(StereoCalibrationTest, ReadsPlainOpenCvFilesIncludingFloatAndRowVectorVariants) {
  StereoCalibration c = MakeCalibration();
  ExpectSameCalibration(DecodeStereoCalibration(PlainOpenCvYaml(c), "plain.yml"), c);
  // Single precision matrices, T as a row, D as a column with 8 coefficients.
  StereoCalibration variant = c;
  c.M1.convertTo(variant.M1, CV_32F);
  variant.T = c.T.t();
  variant.D2 = (cv::Mat_<double>(8, 1) << 1, 2, 3, 4, 5, 6, 7, 8);
  const StereoCalibration read = DecodeStereoCalibration(PlainOpenCvYaml(variant), "variant.yml");
  EXPECT_EQ(read.M1.type(), CV_64FC1);
  EXPECT_NEAR(read.M1.at<double>(0, 0), 700.5, 1e-4);
  EXPECT_EQ(read.T.size(), cv::Size(1, 3));
  EXPECT_EQ(read.T.at<double>(0), -0.12);
  EXPECT_EQ(read.D2.size(), cv::Size(8, 1));
  EXPECT_EQ(read.D2.at<double>(7), 8.0);
}

TEST_F(StereoCalibrationTest, EveryMissingFieldIsNamed) {
  const StereoCalibration c = MakeCalibration();
  std::vector<std::string> all = kMatrixFields;
  all.insert(all.begin(), {"image_width", "image_height"});
  for (const std::string& key : all) {
    WriteTextAtomic(dir_ / "stereo.yml", PlainOpenCvYaml(c, key));
    ExpectInputError([&] { ReadStereoCalibration(dir_ / "stereo.yml"); },
                     {(dir_ / "stereo.yml").string() + ": field '" + key + "' is missing"});
  }
}

TEST_F(StereoCalibrationTest, WrongShapesAndTypesAreNamed) {
  const StereoCalibration good = MakeCalibration();
  struct Case {
    std::string field;
    cv::Mat value;
    std::string message;
  };
  const std::vector<Case> cases = {
      {"M1", cv::Mat::zeros(3, 2, CV_64F), "field 'M1' must be a 3x3 matrix, got 3x2"},
      {"Q", cv::Mat::eye(3, 3, CV_64F), "field 'Q' must be a 4x4 matrix, got 3x3"},
      {"P2", cv::Mat::zeros(3, 3, CV_64F), "field 'P2' must be a 3x4 matrix, got 3x3"},
      {"T", cv::Mat::zeros(2, 2, CV_64F), "field 'T' must be a 3x1 or 1x3 matrix, got 2x2"},
      {"D1", cv::Mat::zeros(1, 3, CV_64F), "field 'D1' must be a 1x4 or 1x5"},
      {"R", cv::Mat::eye(3, 3, CV_8U), "field 'R' must hold floating-point numbers"},
      {"R2", cv::Mat::eye(3, 3, CV_32SC1),
       "field 'R2' must hold floating-point numbers (dt 'd' or 'f'), got dt 'i'"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.field);
    StereoCalibration bad = good;
    const_cast<cv::Mat&>(Field(bad, c.field)) = c.value;
    ExpectInputError([&] { DecodeStereoCalibration(PlainOpenCvYaml(bad), "stereo.yml"); },
                     {"stereo.yml: " + c.message});
  }
}

TEST_F(StereoCalibrationTest, HandEditedMistakesAreNamed) {
  const std::string good = PlainOpenCvYaml(MakeCalibration());
  const auto replace = [&](const std::string& from, const std::string& to) {
    std::string text = good;
    const size_t pos = text.find(from);
    EXPECT_NE(pos, std::string::npos) << from;
    return text.replace(pos, from.size(), to);
  };
  const struct {
    std::string text;
    std::string message;
  } cases[] = {
      {replace("image_width: 640", "image_width: 64.5"),
       "field 'image_width' must be an integer, got a real"},
      {replace("image_width: 640", "image_width: -640"),
       "field 'image_width' = -640 is out of range"},
      {replace("image_height: 480", "image_height: \"480\""),
       "field 'image_height' must be an integer, got a string"},
      {replace("Q: !!opencv-matrix", "Q: 5\nQQ: !!opencv-matrix"),
       "field 'Q' must be a 4x4 !!opencv-matrix, got an integer"},
      {replace("M1: !!opencv-matrix\n   rows: 3", "M1: !!opencv-matrix\n   rows: 2"),
       "field 'M1' must be a 3x3"},
      {replace("M1: !!opencv-matrix\n   rows: 3", "M1: !!opencv-matrix\n   rowz: 3"),
       "field 'M1' must be an !!opencv-matrix with integer 'rows'"},
      {replace("   data: [ 7.0050000000000000e+02,", "   data: [ 7.0050000000000000e+02, 1.0,"),
       "field 'M1' is 3x3 but its data holds 10 numbers"},
      {replace("   data: [ 7.0050000000000000e+02,", "   data: [ abc,"),
       "field 'M1': element 0 is a string"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.message);
    ExpectInputError([&] { DecodeStereoCalibration(c.text, "stereo.yml"); },
                     {"stereo.yml: " + c.message});
  }
}

TEST_F(StereoCalibrationTest, UnparseableFilesAreInputErrorsNamingTheFile) {
  ExpectInputError([&] { ReadStereoCalibration(dir_ / "missing.yml"); },
                   {"missing.yml", "no such file"});
  ExpectInputError([&] { ReadStereoCalibration(dir_); }, {dir_.string(), "is a folder"});
  for (const std::string& text :
       {std::string(""), std::string("  \n"), std::string("%YAML:1.0\nM1: [1, 2\n"),
        std::string("%YAML:1.0\n  a: 1\n b: {\n"), std::string("just some text"),
        std::string("\x89PNG\r\n\x1a\n", 8), std::string("a\0b", 3),
        std::string("%YAML:1.0\nM1: !!opencv-matrix\n   rows: 1\n   : d\n")}) {
    SCOPED_TRACE(text);
    WriteTextAtomic(dir_ / "stereo.yml", text);
    ExpectInputError([&] { ReadStereoCalibration(dir_ / "stereo.yml"); },
                     {(dir_ / "stereo.yml").string()});
  }
}

TEST_F(StereoCalibrationTest, RectifiedFocalAndBaseline) {
  const StereoCalibration c = MakeCalibration();
  EXPECT_EQ(c.RectifiedFocal(), c.P1.at<double>(0, 0));
  EXPECT_GT(c.RectifiedFocal(), 600);
  // stereoRectify puts the whole baseline on the x axis: |T| = 0.12002 m.
  EXPECT_NEAR(c.Baseline(), cv::norm(c.T), 1e-12);
  // A hand-made projection: f = 500, P2(0,3) = -f * B with B = 0.25 m.
  StereoCalibration hand = c;
  hand.P2 = (cv::Mat_<double>(3, 4) << 500, 0, 320, -125, 0, 500, 240, 0, 0, 0, 1, 0);
  EXPECT_DOUBLE_EQ(hand.Baseline(), 0.25);
}

TEST_F(StereoCalibrationTest, RectifiedPinholeCalibrationProjectsWithMiddleburyDoffs) {
  // Middlebury's convention: Z = B f / (d + doffs) with d = x_left - x_right.
  const double f = 999.4, b = 0.193, doffs = 32.8;
  const StereoCalibration c = RectifiedPinholeCalibration({741, 497}, f, 294.2, 252.5, b, doffs);
  EXPECT_DOUBLE_EQ(c.RectifiedFocal(), f);
  EXPECT_NEAR(c.Baseline(), b, 1e-15);
  const cv::Vec4d point(0.3, -0.2, 3.1, 1.0);
  const cv::Mat left = c.P1 * cv::Mat(point), right = c.P2 * cv::Mat(point);
  const double d =
      left.at<double>(0) / left.at<double>(2) - right.at<double>(0) / right.at<double>(2);
  EXPECT_NEAR(b * f / (d + doffs), 3.1, 1e-12);
  // Q maps (x, y, d) back to the point: W = d / B + doffs / B.
  const cv::Mat q = c.Q * (cv::Mat_<double>(4, 1) << left.at<double>(0) / left.at<double>(2),
                           left.at<double>(1) / left.at<double>(2), d, 1.0);
  EXPECT_NEAR(q.at<double>(2) / q.at<double>(3), 3.1, 1e-12);
  EXPECT_NEAR(q.at<double>(0) / q.at<double>(3), 0.3, 1e-12);
  ExpectInputError(
      [] {
        RectifiedPinholeCalibration({64, 48}, 0.0, 32, 24, 0.1);
      },
      {"focal length 0"});
  ExpectInputError(
      [] {
        RectifiedPinholeCalibration({64, 48}, 500, 32, 24, 0.1, NAN);
      },
      {"must be finite"});
}

TEST_F(StereoCalibrationTest, CheckCalibrationMatchesImage) {
  const StereoCalibration c = MakeCalibration();
  EXPECT_NO_THROW(CheckCalibrationMatchesImage(c, cv::Size(640, 480), "stereo.yml"));
  ExpectInputError([&] { CheckCalibrationMatchesImage(c, cv::Size(320, 240), "stereo.yml"); },
                   {"stereo.yml", "640x480", "320x240"});
}

TEST_F(StereoCalibrationTest, RefusesToWriteIncompleteCalibration) {
  StereoCalibration c = MakeCalibration();
  c.Q = cv::Mat();
  ExpectInputError([&] { WriteStereoCalibration(dir_ / "s.yml", c); }, {"Q"});
  EXPECT_TRUE(Files().empty());
}

}  // namespace
}  // namespace linesight
