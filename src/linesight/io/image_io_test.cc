#include "linesight/io/image_io.h"

#include <fstream>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "linesight/io/io_test_util.h"

namespace linesight {
namespace {
namespace fs = std::filesystem;
using testing::ExpectInputError;
using testing::SharedData;

class ImageIoTest : public testing::TempDirTest {};

cv::Mat RandomImage(int rows, int cols, int type, uint64_t seed) {
  cv::Mat image(rows, cols, type);
  cv::RNG rng(seed);
  rng.fill(image, cv::RNG::UNIFORM, 0, image.depth() == CV_16U ? 65536 : 256);
  return image;
}

bool Identical(const cv::Mat& a, const cv::Mat& b) {
  return a.type() == b.type() && a.size() == b.size() && cv::norm(a, b, cv::NORM_INF) == 0;
}

TEST_F(ImageIoTest, PngRoundTripIsExactFor8And16BitGreyAndColour) {
  for (int type : {CV_8UC1, CV_8UC3, CV_16UC1, CV_16UC3}) {
    SCOPED_TRACE(type);
    const cv::Mat image = RandomImage(7, 13, type, 1234 + type);
    WriteImage(dir_ / "a.png", image);
    EXPECT_TRUE(Identical(ReadImage(dir_ / "a.png", ImageColor::kUnchanged), image));
  }
  EXPECT_EQ(Files(), std::vector<std::string>{"a.png"});  // no temporary file left behind
}

TEST_F(ImageIoTest, GrayAndColorModesConvert) {
  const cv::Mat colour = RandomImage(5, 6, CV_8UC3, 7);
  WriteImage(dir_ / "c.png", colour);
  const cv::Mat grey = ReadImage(dir_ / "c.png", ImageColor::kGray);
  ASSERT_EQ(grey.type(), CV_8UC1);
  const cv::Vec3b p = colour.at<cv::Vec3b>(2, 3);
  EXPECT_NEAR(grey.at<uint8_t>(2, 3), 0.114 * p[0] + 0.587 * p[1] + 0.299 * p[2], 1.0);

  const cv::Mat grey16 = RandomImage(5, 6, CV_16UC1, 8);
  WriteImage(dir_ / "g16.png", grey16);
  const cv::Mat as_colour = ReadImage(dir_ / "g16.png", ImageColor::kColor);
  ASSERT_EQ(as_colour.type(), CV_8UC3);
  EXPECT_EQ(as_colour.at<cv::Vec3b>(1, 1)[0], grey16.at<uint16_t>(1, 1) >> 8);
}

TEST_F(ImageIoTest, PalettePngIsMappedToGreyValues) {
  const fs::path path = SharedData("middlebury-2001-2003/tsukuba/groundtruth.png");
  if (!fs::exists(path)) GTEST_SKIP() << path << " is missing (shared data not installed)";
  for (ImageColor color : {ImageColor::kUnchanged, ImageColor::kGray}) {
    const cv::Mat gt = ReadImage(path, color);
    ASSERT_EQ(gt.type(), CV_8UC1);
    EXPECT_EQ(gt.size(), cv::Size(384, 288));
    double min_value = 0, max_value = 0;
    cv::minMaxLoc(gt, &min_value, &max_value, nullptr, nullptr, gt > 0);
    // Middlebury's scale for tsukuba is 16: 80..224 = 5..14 px (raw palette indices would be 0..7).
    EXPECT_EQ(min_value, 80);
    EXPECT_EQ(max_value, 224);
  }
}

TEST_F(ImageIoTest, MissingEmptyAndNonImageFilesNameTheFile) {
  const fs::path missing = dir_ / "missing.png";
  ExpectInputError([&] { ReadImage(missing, ImageColor::kGray); },
                   {missing.string(), "no such file", "image"});

  const fs::path empty = dir_ / "empty.png";
  std::ofstream(empty).close();
  ExpectInputError([&] { ReadImage(empty, ImageColor::kColor); },
                   {empty.string(), "empty", "image"});

  const fs::path text = dir_ / "notes.png";
  std::ofstream(text) << "this is not an image\n";
  ExpectInputError([&] { ReadImage(text, ImageColor::kUnchanged); },
                   {text.string(), "cannot decode", "PNG"});

  ExpectInputError([&] { ReadImage(dir_, ImageColor::kUnchanged); }, {dir_.string(), "folder"});
}

TEST_F(ImageIoTest, TruncatedPngIsAnInputError) {
  WriteImage(dir_ / "full.png", RandomImage(64, 64, CV_8UC3, 3));
  std::string bytes;
  {
    std::ifstream in(dir_ / "full.png", std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  std::ofstream(dir_ / "cut.png", std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  ExpectInputError([&] { ReadImage(dir_ / "cut.png", ImageColor::kUnchanged); }, {"cut.png"});
}

TEST_F(ImageIoTest, FailedWritesLeaveNoFile) {
  const cv::Mat image = RandomImage(4, 4, CV_8UC1, 5);
  ExpectInputError([&] { WriteImage(dir_ / "a.unknownext", image); }, {"a.unknownext"});
  ExpectInputError([&] { WriteImage(dir_ / "no_such_folder" / "a.png", image); },
                   {"no_such_folder"});
  ExpectInputError([&] { WriteImage(dir_ / "e.png", cv::Mat()); }, {"e.png", "empty"});
  EXPECT_TRUE(Files().empty());
}

TEST_F(ImageIoTest, WriteReplacesAnExistingFile) {
  WriteImage(dir_ / "a.png", RandomImage(4, 4, CV_8UC1, 1));
  const cv::Mat second = RandomImage(6, 5, CV_8UC1, 2);
  WriteImage(dir_ / "a.png", second);
  EXPECT_TRUE(Identical(ReadImage(dir_ / "a.png", ImageColor::kUnchanged), second));
}

TEST(CheckSameSizeTest, MessageNamesBothFilesAndSizes) {
  const cv::Mat left(480, 640, CV_8UC1), right(240, 320, CV_8UC1);
  EXPECT_NO_THROW(CheckSameSize(left, "left.png", left, "right.png"));
  const std::string message =
      ExpectInputError([&] { CheckSameSize(left, "left.png", right, "right.png"); },
                       {"left.png is 640x480", "right.png is 320x240"});
  EXPECT_FALSE(message.empty());
}

}  // namespace
}  // namespace linesight
