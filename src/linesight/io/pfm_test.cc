#include "linesight/io/pfm.h"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

#include <gtest/gtest.h>

#include "linesight/core/atomic_file.h"
#include "linesight/io/io_test_util.h"

namespace linesight {
namespace {
namespace fs = std::filesystem;
using testing::ExpectInputError;
using testing::SharedData;

class PfmTest : public testing::TempDirTest {};

std::string FloatBytes(float value, bool big_endian) {
  std::uint32_t bits;
  std::memcpy(&bits, &value, 4);
  std::string out(4, '\0');
  for (int i = 0; i < 4; ++i) {
    const int shift = big_endian ? 24 - 8 * i : 8 * i;
    out[i] = static_cast<char>((bits >> shift) & 0xff);
  }
  return out;
}

bool BitIdentical(const cv::Mat& a, const cv::Mat& b) {
  if (a.type() != b.type() || a.size() != b.size()) return false;
  for (int y = 0; y < a.rows; ++y) {
    if (std::memcmp(a.ptr(y), b.ptr(y), a.cols * a.elemSize()) != 0) return false;
  }
  return true;
}

cv::Mat SpecialValues(int rows, int cols, int channels) {
  cv::Mat image(rows, cols, CV_MAKETYPE(CV_32F, channels));
  cv::RNG rng(42);
  rng.fill(image, cv::RNG::UNIFORM, -1000.0, 1000.0);
  auto* data = image.ptr<float>(0);
  data[0] = std::numeric_limits<float>::infinity();
  data[1] = -std::numeric_limits<float>::infinity();
  data[2] = std::numeric_limits<float>::quiet_NaN();
  data[3] = -0.0f;
  data[4] = std::numeric_limits<float>::denorm_min();
  data[5] = std::numeric_limits<float>::max();
  std::uint32_t nan_with_payload = 0x7fc12345;  // a NaN payload must survive too
  std::memcpy(&data[6], &nan_with_payload, 4);
  image.at<float>(rows - 1, 0) = -123.456f;
  return image;
}

TEST_F(PfmTest, RoundTripIsBitExactForGreyAndColourWithSpecialValues) {
  for (int channels : {1, 3}) {
    for (cv::Size size : {cv::Size(7, 5), cv::Size(1, 9), cv::Size(13, 1)}) {
      SCOPED_TRACE(::testing::Message() << channels << " channels, " << size);
      const cv::Mat image = SpecialValues(size.height, size.width, channels);
      EXPECT_TRUE(BitIdentical(DecodePfm(EncodePfm(image), "mem"), image));
      WritePfm(dir_ / "x.pfm", image);
      EXPECT_TRUE(BitIdentical(ReadPfm(dir_ / "x.pfm"), image));
    }
  }
  EXPECT_EQ(Files(), std::vector<std::string>{"x.pfm"});
}

TEST_F(PfmTest, EncodesMiddleburyLayout) {
  cv::Mat image = (cv::Mat_<float>(2, 3) << 1, 2, 3, 4, 5, 6);
  const std::string bytes = EncodePfm(image);
  const std::string header = "Pf\n3 2\n-1.0\n";
  ASSERT_EQ(bytes.size(), header.size() + 6 * 4);
  EXPECT_EQ(bytes.substr(0, header.size()), header);
  // Bottom row first, little-endian.
  EXPECT_EQ(bytes.substr(header.size(), 4), FloatBytes(4.0f, false));
  EXPECT_EQ(bytes.substr(header.size() + 12, 4), FloatBytes(1.0f, false));
  // A non-contiguous view (odd region of a bigger image) writes the same bytes as a copy.
  const cv::Mat big = SpecialValues(9, 11, 1);
  const cv::Mat view = big(cv::Rect(3, 2, 5, 4));
  EXPECT_EQ(EncodePfm(view), EncodePfm(view.clone()));
}

TEST_F(PfmTest, ReadsBigEndianAndIgnoresScaleMagnitude) {
  const float values[4] = {1.5f, -2.25f, std::numeric_limits<float>::infinity(), 1e-3f};
  for (const char* scale : {"1.0", "0.5", "3e2"}) {
    std::string be = std::string("Pf\n2 2\n") + scale + "\n";
    std::string le = std::string("Pf\n2 2\n-") + scale + "\n";
    for (float v : values) {
      be += FloatBytes(v, true);
      le += FloatBytes(v, false);
    }
    for (const std::string& bytes : {be, le}) {
      const cv::Mat image = DecodePfm(bytes, "mem");
      ASSERT_EQ(image.type(), CV_32FC1);
      ASSERT_EQ(image.size(), cv::Size(2, 2));
      // File rows run bottom-to-top: the first two values are the bottom row.
      EXPECT_EQ(image.at<float>(1, 0), 1.5f);
      EXPECT_EQ(image.at<float>(1, 1), -2.25f);
      EXPECT_EQ(image.at<float>(0, 0), std::numeric_limits<float>::infinity());
      EXPECT_EQ(image.at<float>(0, 1), 1e-3f);
    }
  }
}

TEST_F(PfmTest, AcceptsHeaderWhitespaceVariants) {
  const std::string data = FloatBytes(7.0f, false) + FloatBytes(8.0f, false);
  for (const char* header : {"Pf\n2 1\n-1\n", "Pf \n2 1 \n-1.0\n", "Pf\n2\n1\n-1\n",
                             "Pf\r\n2 1\r\n-1.0\r\n", "Pf 2 1 -1 "}) {
    SCOPED_TRACE(header);
    const cv::Mat image = DecodePfm(header + data, "mem");
    ASSERT_EQ(image.size(), cv::Size(2, 1));
    EXPECT_EQ(image.at<float>(0, 1), 8.0f);
  }
}

TEST_F(PfmTest, MalformedHeadersGiveClearErrors) {
  const std::string four = std::string(16, '\0');
  const struct {
    std::string bytes;
    std::vector<std::string> parts;
  } cases[] = {
      {"", {"bad.pfm", "\"Pf\""}},
      {"P6\n2 2\n255\n" + four, {"bad.pfm", "must start with", "P6"}},
      {"Pg\n2 2\n-1\n" + four, {"must start with"}},
      {"Pfx\n2 2\n-1\n" + four, {"whitespace after"}},
      {"Pf\nabc 2\n-1\n" + four, {"width", "'abc'", "not a positive integer"}},
      {"Pf\n-2 2\n-1\n" + four, {"width", "'-2'"}},
      {"Pf\n+2 2\n-1\n" + four, {"width", "'+2'"}},
      {"Pf\n2.5 2\n-1\n" + four, {"width", "'2.5'"}},
      {"Pf\n0 2\n-1\n", {"width 0", "out of range"}},
      {"Pf\n2 0\n-1\n", {"height 0", "out of range"}},
      {"Pf\n99999999999999999999999 2\n-1\n", {"width"}},
      {"Pf\n1000000000 1\n-1\n", {"width 1000000000", "out of range"}},
      {"Pf\n100000 100000\n-1\n", {"100000x100000x1", "more than"}},
      {"PF\n10000 10000\n-1\n", {"10000x10000x3", "more than"}},
      {"Pf\n2 2\n", {"ends before the scale"}},
      {"Pf\n2", {"ends before the height"}},
      {"Pf\n2 2\nscale\n" + four, {"scale 'scale' is not a number"}},
      {"Pf\n2 2\n0\n" + four, {"scale 0", "non-zero"}},
      {"Pf\n2 2\n-0.0\n" + four, {"non-zero"}},
      {"Pf\n2 2\nnan\n" + four, {"scale nan"}},
      {"Pf\n2 2\ninf\n" + four, {"scale inf"}},
      {"Pf\n2 2\n-1\n" + four.substr(0, 12), {"truncated", "2x2 grey", "16 bytes", "has 12"}},
      {"PF\n2 2\n-1\n" + four, {"truncated", "2x2 colour", "48 bytes", "has 16"}},
      {"Pf\n2 2\n-1", {"truncated", "has 0"}},
      {"Pf\n2 2\n-1\n" + four + "xx", {"longer than its header says", "has 18"}},
      {"Pf\n" + std::string(200, '7') + " 2\n-1\n", {"width", "not a short token"}},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.bytes.substr(0, 40));
    const std::string message =
        ExpectInputError([&] { DecodePfm(c.bytes, "bad.pfm"); }, {"bad.pfm"});
    for (const std::string& part : c.parts)
      EXPECT_NE(message.find(part), std::string::npos) << message;
  }
}

TEST_F(PfmTest, FileErrorsNameTheFileAndLeaveNoOutput) {
  ExpectInputError([&] { ReadPfm(dir_ / "missing.pfm"); }, {"missing.pfm", "no such file"});
  ExpectInputError([&] { ReadPfm(dir_); }, {dir_.string(), "is a folder"});
  WriteTextAtomic(dir_ / "cut.pfm", "Pf\n4 4\n-1\n" + std::string(10, '\0'));
  ExpectInputError([&] { ReadPfm(dir_ / "cut.pfm"); },
                   {"cut.pfm", "truncated", "64 bytes", "has 10"});
  ExpectInputError([&] { WritePfm(dir_ / "u8.pfm", cv::Mat(2, 2, CV_8UC1)); }, {"CV_32FC1"});
  ExpectInputError([&] { WritePfm(dir_ / "e.pfm", cv::Mat()); }, {"non-empty"});
  EXPECT_EQ(Files(), std::vector<std::string>{"cut.pfm"});
}

void ExpectFiniteRange(const cv::Mat& d, double lo, double hi, double tolerance) {
  double min_value = INFINITY, max_value = -INFINITY;
  int finite = 0;
  for (int y = 0; y < d.rows; ++y) {
    for (int x = 0; x < d.cols; ++x) {
      const float v = d.at<float>(y, x);
      if (!std::isfinite(v)) continue;
      ++finite;
      min_value = std::min<double>(min_value, v);
      max_value = std::max<double>(max_value, v);
    }
  }
  ASSERT_GT(finite, 0);
  EXPECT_NEAR(min_value, lo, tolerance);
  EXPECT_NEAR(max_value, hi, tolerance);
}

TEST_F(PfmTest, ReadsMiddlebury2014Motorcycle) {
  const fs::path path = SharedData("middlebury-2014-quarter/Motorcycle/disp0GT.pfm");
  if (!fs::exists(path)) GTEST_SKIP() << path << " is missing (shared data not installed)";
  const cv::Mat d = ReadPfm(path);
  ASSERT_EQ(d.type(), CV_32FC1);
  EXPECT_EQ(d.size(), cv::Size(741, 497));
  ExpectFiniteRange(d, 9.18, 62.88, 0.005);
  EXPECT_GT(cv::countNonZero(d == std::numeric_limits<float>::infinity()),
            0);  // unknown pixels are +inf
  // Bit-exact rewrite of a real file.
  WritePfm(dir_ / "copy.pfm", d);
  EXPECT_TRUE(BitIdentical(ReadPfm(dir_ / "copy.pfm"), d));
}

TEST_F(PfmTest, ReadsEth3dAndSceneFlowHeaders) {
  const fs::path eth3d = SharedData("eth3d-two-view/terrace/disp0.pfm");
  const fs::path sceneflow = SharedData("sceneflow-sample/disparity/left/A-0032-0006.pfm");
  if (!fs::exists(eth3d) || !fs::exists(sceneflow)) GTEST_SKIP() << "shared data not installed";
  const cv::Mat terrace = ReadPfm(eth3d);  // header "Pf\n713 434\n-1\n"
  EXPECT_EQ(terrace.size(), cv::Size(713, 434));
  ExpectFiniteRange(terrace, 8, 17, 1.0);
  const cv::Mat flying = ReadPfm(sceneflow);  // header "Pf \n960 540 \n-1.0\n"
  EXPECT_EQ(flying.size(), cv::Size(960, 540));
  EXPECT_EQ(cv::countNonZero(flying != flying), 0);  // no NaN
}

}  // namespace
}  // namespace linesight
