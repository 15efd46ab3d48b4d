// The PNG and JPEG codecs against OpenCV's imgcodecs: the same pixels, type and size as
// cv::imdecode for every PNG colour type and bit depth, palettes with and without transparency,
// interlacing, JPEG quality, progressive, optimised and restart-interval modes, awkward sizes,
// truncated files and the sample images on disk; variants left to OpenCV are declined.
#include "linesight/io/image_codecs.h"

#include <csetjmp>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>

#include <gtest/gtest.h>
#include <png.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "linesight/io/io_test_util.h"

namespace linesight::detail {
namespace {
namespace fs = std::filesystem;

constexpr int kFlags[] = {cv::IMREAD_GRAYSCALE, cv::IMREAD_COLOR, cv::IMREAD_UNCHANGED};

std::vector<uint8_t> ReadBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

bool Identical(const cv::Mat& a, const cv::Mat& b) {
  if (a.type() != b.type() || a.size() != b.size()) return false;
  return a.empty() || cv::norm(a, b, cv::NORM_INF) == 0;
}

// Decodes with both and expects the same result; returns false when ours declined.
bool ExpectSameAsOpenCv(const std::vector<uint8_t>& bytes, int flags) {
  SCOPED_TRACE(::testing::Message() << "flags " << flags);
  cv::Mat ours;
  const DecodeStatus status = DecodePngOrJpeg(bytes, flags, &ours);
  if (status == DecodeStatus::kNotHandled) return false;
  const cv::Mat theirs = cv::imdecode(bytes, flags);
  if (status == DecodeStatus::kCorrupt) {
    EXPECT_TRUE(theirs.empty());
  } else {
    EXPECT_FALSE(theirs.empty());
    EXPECT_TRUE(Identical(ours, theirs))
        << "ours " << ours.size() << " type " << ours.type() << ", OpenCV " << theirs.size()
        << " type " << theirs.type();
  }
  return true;
}

// A PNG of any colour type, bit depth and interlacing (OpenCV's encoder writes only some),
// written with libpng. `samples` holds width * channels values per row, each < 2^bit_depth.
struct RawPng {
  int width = 0, height = 0, bit_depth = 8, color_type = PNG_COLOR_TYPE_GRAY;
  bool interlaced = false;
  std::vector<png_color> palette;
  std::vector<png_byte> palette_alpha;      // tRNS of a palette image
  std::optional<png_color_16> trans_color;  // tRNS of a grey or RGB image
  std::vector<uint16_t> samples;
};

void AppendBytes(png_structp png, png_bytep data, size_t n) {
  auto* out = static_cast<std::vector<uint8_t>*>(png_get_io_ptr(png));
  out->insert(out->end(), data, data + n);
}

int Channels(int color_type) {
  switch (color_type) {
    case PNG_COLOR_TYPE_GRAY_ALPHA:
      return 2;
    case PNG_COLOR_TYPE_RGB:
      return 3;
    case PNG_COLOR_TYPE_RGB_ALPHA:
      return 4;
    default:
      return 1;
  }
}

// Packs the samples into PNG rows (MSB first below 8 bits, big-endian at 16).
std::vector<std::vector<png_byte>> PackRows(const RawPng& p) {
  const int per_row = p.width * Channels(p.color_type);
  std::vector<std::vector<png_byte>> rows(p.height);
  for (int y = 0; y < p.height; ++y) {
    std::vector<png_byte>& row = rows[y];
    row.assign((static_cast<size_t>(per_row) * p.bit_depth + 7) / 8, 0);
    for (int i = 0; i < per_row; ++i) {
      const uint16_t v = p.samples[static_cast<size_t>(y) * per_row + i];
      if (p.bit_depth == 16) {
        row[2 * i] = static_cast<png_byte>(v >> 8);
        row[2 * i + 1] = static_cast<png_byte>(v & 0xff);
      } else if (p.bit_depth == 8) {
        row[i] = static_cast<png_byte>(v);
      } else {
        const int bit = i * p.bit_depth;
        row[bit / 8] |= static_cast<png_byte>(v << (8 - p.bit_depth - bit % 8));
      }
    }
  }
  return rows;
}

bool WriteRawPng(const RawPng& p, std::vector<std::vector<png_byte>>& rows,
                 std::vector<png_bytep>& pointers, std::vector<uint8_t>* out) {
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png_create_info_struct(png);
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    return false;
  }
  png_set_write_fn(png, out, AppendBytes, nullptr);
  png_set_IHDR(png, info, p.width, p.height, p.bit_depth, p.color_type,
               p.interlaced ? PNG_INTERLACE_ADAM7 : PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  if (!p.palette.empty()) {
    png_set_PLTE(png, info, p.palette.data(), static_cast<int>(p.palette.size()));
  }
  if (!p.palette_alpha.empty()) {
    png_set_tRNS(png, info, p.palette_alpha.data(), static_cast<int>(p.palette_alpha.size()),
                 nullptr);
  }
  if (p.trans_color) {
    png_color_16 colour = *p.trans_color;
    png_set_tRNS(png, info, nullptr, 0, &colour);
  }
  png_write_info(png, info);
  for (auto& row : rows) pointers.push_back(row.data());
  png_write_image(png, pointers.data());
  png_write_end(png, info);
  png_destroy_write_struct(&png, &info);
  return true;
}

std::vector<uint8_t> EncodeRawPng(const RawPng& p) {
  std::vector<std::vector<png_byte>> rows = PackRows(p);
  std::vector<png_bytep> pointers;
  std::vector<uint8_t> out;
  EXPECT_TRUE(WriteRawPng(p, rows, pointers, &out));
  return out;
}

RawPng RandomRawPng(int width, int height, int bit_depth, int color_type, uint64_t seed) {
  RawPng p;
  p.width = width;
  p.height = height;
  p.bit_depth = bit_depth;
  p.color_type = color_type;
  cv::RNG rng(seed);
  const int levels = 1 << bit_depth;
  if (color_type == PNG_COLOR_TYPE_PALETTE) {
    for (int i = 0; i < levels; ++i) {
      p.palette.push_back({static_cast<png_byte>(rng.uniform(0, 256)),
                           static_cast<png_byte>(rng.uniform(0, 256)),
                           static_cast<png_byte>(rng.uniform(0, 256))});
    }
  }
  p.samples.resize(static_cast<size_t>(width) * height * Channels(color_type));
  for (uint16_t& v : p.samples) v = static_cast<uint16_t>(rng.uniform(0, levels));
  return p;
}

TEST(ImageCodecsTest, EveryPngColourTypeAndBitDepthDecodesAsOpenCv) {
  const struct {
    int color_type;
    std::vector<int> depths;
  } kinds[] = {{PNG_COLOR_TYPE_GRAY, {1, 2, 4, 8, 16}},
               {PNG_COLOR_TYPE_GRAY_ALPHA, {8, 16}},
               {PNG_COLOR_TYPE_RGB, {8, 16}},
               {PNG_COLOR_TYPE_RGB_ALPHA, {8, 16}},
               {PNG_COLOR_TYPE_PALETTE, {1, 2, 4, 8}}};
  uint64_t seed = 1;
  for (const auto& kind : kinds) {
    for (int depth : kind.depths) {
      for (bool interlaced : {false, true}) {
        for (const cv::Size size : {cv::Size(1, 1), cv::Size(13, 7), cv::Size(37, 23)}) {
          SCOPED_TRACE(::testing::Message() << "colour type " << kind.color_type << ", " << depth
                                            << " bit, interlaced " << interlaced << ", " << size);
          RawPng p = RandomRawPng(size.width, size.height, depth, kind.color_type, seed++);
          p.interlaced = interlaced;
          const std::vector<uint8_t> bytes = EncodeRawPng(p);
          for (int flags : kFlags) EXPECT_TRUE(ExpectSameAsOpenCv(bytes, flags));
        }
      }
    }
  }
}

TEST(ImageCodecsTest, TransparencyChunksDecodeAsOpenCv) {
  RawPng palette = RandomRawPng(19, 11, 8, PNG_COLOR_TYPE_PALETTE, 5);
  palette.palette_alpha = {0, 128, 255, 17};
  RawPng grey = RandomRawPng(19, 11, 16, PNG_COLOR_TYPE_GRAY, 6);
  grey.trans_color = png_color_16{0, 0, 0, 0, 1000};
  RawPng rgb = RandomRawPng(19, 11, 8, PNG_COLOR_TYPE_RGB, 7);
  rgb.trans_color = png_color_16{0, 10, 20, 30, 0};
  for (const RawPng* p : {&palette, &grey, &rgb}) {
    const std::vector<uint8_t> bytes = EncodeRawPng(*p);
    for (int flags : kFlags) EXPECT_TRUE(ExpectSameAsOpenCv(bytes, flags));
  }
}

TEST(ImageCodecsTest, JpegModesAndSizesDecodeAsOpenCv) {
  cv::RNG rng(11);
  for (const cv::Size size :
       {cv::Size(1, 1), cv::Size(17, 9), cv::Size(64, 48), cv::Size(101, 77)}) {
    cv::Mat colour(size, CV_8UC3);
    rng.fill(colour, cv::RNG::UNIFORM, 0, 256);
    cv::GaussianBlur(colour, colour, cv::Size(3, 3), 0);  // some structure to compress
    cv::Mat grey;
    cv::cvtColor(colour, grey, cv::COLOR_BGR2GRAY);
    for (const cv::Mat* image : {&colour, &grey}) {
      for (const std::vector<int>& params :
           std::vector<std::vector<int>>{{cv::IMWRITE_JPEG_QUALITY, 95},
                                         {cv::IMWRITE_JPEG_QUALITY, 40},
                                         {cv::IMWRITE_JPEG_PROGRESSIVE, 1},
                                         {cv::IMWRITE_JPEG_OPTIMIZE, 1},
                                         {cv::IMWRITE_JPEG_RST_INTERVAL, 3},
                                         {cv::IMWRITE_JPEG_CHROMA_QUALITY, 20}}) {
        SCOPED_TRACE(::testing::Message() << size << " channels " << image->channels() << " param "
                                          << params[0] << "=" << params[1]);
        std::vector<uint8_t> bytes;
        ASSERT_TRUE(cv::imencode(".jpg", *image, bytes, params));
        for (int flags : kFlags) EXPECT_TRUE(ExpectSameAsOpenCv(bytes, flags));
      }
    }
  }
}

TEST(ImageCodecsTest, TruncatedFilesBehaveAsInOpenCv) {
  cv::Mat colour(40, 50, CV_8UC3);
  cv::RNG(3).fill(colour, cv::RNG::UNIFORM, 0, 256);
  for (const char* extension : {".png", ".jpg"}) {
    std::vector<uint8_t> bytes;
    ASSERT_TRUE(cv::imencode(extension, colour, bytes));
    for (size_t keep : {size_t{9}, size_t{40}, bytes.size() / 2, bytes.size() - 3}) {
      SCOPED_TRACE(::testing::Message() << extension << " cut to " << keep << " bytes");
      const std::vector<uint8_t> cut(bytes.begin(), bytes.begin() + keep);
      for (int flags : kFlags) {
        if (std::string(extension) == ".png") {
          EXPECT_TRUE(ExpectSameAsOpenCv(cut, flags));
        } else {
          // OpenCV returns a JPEG cut short with the missing rows uninitialised; it is corrupt.
          cv::Mat image;
          EXPECT_EQ(DecodePngOrJpeg(cut, flags, &image), DecodeStatus::kCorrupt);
        }
      }
    }
  }
}

TEST(ImageCodecsTest, ExifJpegsAndOtherFormatsAreLeftToOpenCv) {
  cv::Mat grey(8, 8, CV_8UC1, cv::Scalar(90));
  std::vector<uint8_t> jpeg;
  ASSERT_TRUE(cv::imencode(".jpg", grey, jpeg));
  // An EXIF segment right after SOI whose IFD0 holds one entry, the orientation. OpenCV turns
  // the image for orientations other than 1, so it decodes those; unreadable EXIF too.
  auto with_orientation = [&](uint8_t orientation) {
    const std::vector<uint8_t> app1 = {
        0xFF, 0xE1, 0x00, 0x22, 'E', 'x', 'i', 'f', 0, 0, 'I',         'I', 42, 0, 8, 0, 0, 0,
        1,    0,    0x12, 0x01, 3,   0,   1,   0,   0, 0, orientation, 0,   0,  0, 0, 0, 0, 0};
    std::vector<uint8_t> out = jpeg;
    out.insert(out.begin() + 2, app1.begin(), app1.end());
    return out;
  };
  cv::Mat image;
  for (uint8_t orientation : {3, 6, 8}) {
    EXPECT_EQ(DecodePngOrJpeg(with_orientation(orientation), cv::IMREAD_GRAYSCALE, &image),
              DecodeStatus::kNotHandled);
  }
  for (int flags : kFlags) EXPECT_TRUE(ExpectSameAsOpenCv(with_orientation(1), flags));
  std::vector<uint8_t> unreadable = with_orientation(6);
  unreadable[14] = 200;  // IFD0 beyond the segment
  EXPECT_EQ(DecodePngOrJpeg(unreadable, cv::IMREAD_COLOR, &image), DecodeStatus::kNotHandled);
  for (const char* extension : {".bmp", ".tif", ".pgm", ".webp"}) {
    std::vector<uint8_t> bytes;
    ASSERT_TRUE(cv::imencode(extension, grey, bytes));
    EXPECT_EQ(DecodePngOrJpeg(bytes, cv::IMREAD_UNCHANGED, &image), DecodeStatus::kNotHandled)
        << extension;
  }
  EXPECT_EQ(DecodePngOrJpeg({}, cv::IMREAD_UNCHANGED, &image), DecodeStatus::kNotHandled);
}

TEST(ImageCodecsTest, SampleImagesOnDiskDecodeAsOpenCv) {
  std::vector<fs::path> files;
  const fs::path opencv_data = LINESIGHT_OPENCV_DATA_DIR;
  for (const char* name : {"aloeL.jpg", "aloeGT.png", "left01.jpg", "graf1.png", "leuvenA.jpg",
                           "chessboard.png", "HappyFish.jpg", "opencv-logo.png"}) {
    if (fs::exists(opencv_data / name)) files.push_back(opencv_data / name);
  }
  std::error_code ec;
  for (const char* set : {"middlebury-2005-2006-half", "middlebury-2014-quarter"}) {
    size_t taken = 0;
    for (auto it = fs::recursive_directory_iterator(testing::SharedData(set), ec);
         !ec && it != fs::recursive_directory_iterator() && taken < 12; it.increment(ec)) {
      if (it->path().extension() == ".png") {
        files.push_back(it->path());
        ++taken;
      }
    }
  }
  if (files.empty()) GTEST_SKIP() << "no sample images (opencv-doc, ../shared/data)";
  for (const fs::path& file : files) {
    SCOPED_TRACE(file.string());
    const std::vector<uint8_t> bytes = ReadBytes(file);
    for (int flags : kFlags) EXPECT_TRUE(ExpectSameAsOpenCv(bytes, flags));
  }
}

TEST(ImageCodecsTest, PngEncoderRoundTripsEveryStoredType) {
  cv::RNG rng(21);
  for (int type : {CV_8UC1, CV_8UC3, CV_8UC4, CV_16UC1, CV_16UC3, CV_16UC4}) {
    SCOPED_TRACE(type);
    cv::Mat image(23, 37, type);
    rng.fill(image, cv::RNG::UNIFORM, 0, CV_MAT_DEPTH(type) == CV_16U ? 65536 : 256);
    std::vector<uint8_t> bytes;
    ASSERT_TRUE(EncodePng(image, &bytes));
    EXPECT_TRUE(Identical(cv::imdecode(bytes, cv::IMREAD_UNCHANGED), image));
  }
  std::vector<uint8_t> bytes;
  EXPECT_FALSE(EncodePng(cv::Mat(4, 4, CV_32FC1, cv::Scalar(1)), &bytes));
  EXPECT_FALSE(EncodePng(cv::Mat(4, 4, CV_8UC2, cv::Scalar(1)), &bytes));
  EXPECT_FALSE(EncodePng(cv::Mat(), &bytes));
}

TEST(ImageCodecsTest, JpegEncoderMatchesOpenCvsAtTheSameQuality) {
  cv::Mat colour(48, 67, CV_8UC3);
  cv::RNG(8).fill(colour, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(colour, colour, cv::Size(5, 5), 0);
  cv::Mat grey;
  cv::cvtColor(colour, grey, cv::COLOR_BGR2GRAY);
  for (const cv::Mat* image : {&colour, &grey}) {
    for (int quality : {50, 80, 95}) {
      SCOPED_TRACE(::testing::Message()
                   << "channels " << image->channels() << " quality " << quality);
      std::vector<uint8_t> ours, theirs;
      ASSERT_TRUE(EncodeJpeg(*image, quality, &ours));
      ASSERT_TRUE(cv::imencode(".jpg", *image, theirs, {cv::IMWRITE_JPEG_QUALITY, quality}));
      // The same libjpeg with the same settings: the same pixels once decoded.
      EXPECT_TRUE(Identical(cv::imdecode(ours, cv::IMREAD_UNCHANGED),
                            cv::imdecode(theirs, cv::IMREAD_UNCHANGED)));
    }
  }
  std::vector<uint8_t> bytes;
  EXPECT_FALSE(EncodeJpeg(cv::Mat(4, 4, CV_16UC1, cv::Scalar(1)), 90, &bytes));
}

}  // namespace
}  // namespace linesight::detail
