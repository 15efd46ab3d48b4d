#include "linesight/io/image_codecs.h"

#include <algorithm>
#include <csetjmp>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <string_view>

// clang-format off: jpeglib.h needs <cstdio> first.
#include <jerror.h>
#include <jpeglib.h>
#include <png.h>
// clang-format on

#include <opencv2/imgcodecs.hpp>  // the IMREAD_* flag values only (an enum, nothing to link)

namespace linesight::detail {
namespace {

// cv::imdecode's limits (CV_IO_MAX_IMAGE_WIDTH/HEIGHT/PIXELS): beyond them it throws, so the
// fallback gives the same error.
constexpr uint64_t kMaxSide = uint64_t{1} << 20;
constexpr uint64_t kMaxPixels = uint64_t{1} << 30;

bool SizeAcceptedByOpenCv(uint64_t width, uint64_t height) {
  return width > 0 && height > 0 && width <= kMaxSide && height <= kMaxSide &&
         width * height <= kMaxPixels;
}

// The type cv::imdecode allocates for a decoder of `native` type under `flags`.
int TypeForFlags(int native, int flags) {
  if (flags == cv::IMREAD_UNCHANGED) return native;
  const int channels = (flags & cv::IMREAD_COLOR) != 0 ? 3 : 1;
  return CV_MAKETYPE(CV_8U, channels);
}

// ---------------------------------------------------------------------------------------------
// PNG
// ---------------------------------------------------------------------------------------------

constexpr uint8_t kPngSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};

bool IsPng(std::span<const uint8_t> bytes) {
  return bytes.size() >= 8 && std::memcmp(bytes.data(), kPngSignature, 8) == 0;
}

// True when a chunk before the image data makes OpenCV read the file differently from plain
// libpng: an EXIF block (its orientation may be applied) or an animation (APNG).
bool PngHasChunksLeftToOpenCv(std::span<const uint8_t> bytes) {
  size_t pos = 8;
  while (pos + 8 <= bytes.size()) {
    const uint64_t length = (uint64_t{bytes[pos]} << 24) | (uint64_t{bytes[pos + 1]} << 16) |
                            (uint64_t{bytes[pos + 2]} << 8) | uint64_t{bytes[pos + 3]};
    const std::string_view type(reinterpret_cast<const char*>(bytes.data() + pos + 4), 4);
    if (type == "IDAT") return false;
    if (type == "eXIf" || type == "acTL") return true;
    pos += 12 + length;
  }
  return false;
}

struct PngSource {
  std::span<const uint8_t> bytes;
  size_t pos = 0;
};

void ReadPngBytes(png_structp png, png_bytep out, size_t count) {
  auto* source = static_cast<PngSource*>(png_get_io_ptr(png));
  if (count > source->bytes.size() - source->pos) png_error(png, "PNG data ends early");
  std::memcpy(out, source->bytes.data() + source->pos, count);
  source->pos += count;
}

// libpng's default handlers print; a failure is reported once, by the caller, with the file name.
void PngError(png_structp png, png_const_charp) { png_longjmp(png, 1); }
void PngWarning(png_structp, png_const_charp) {}

struct PngReadStructs {
  png_structp png = nullptr;
  png_infop info = nullptr;
  png_infop end = nullptr;
  PngReadStructs() {
    png = png_create_read_struct(PNG_LIBPNG_VER_STRING, nullptr, PngError, PngWarning);
    if (png) {
      info = png_create_info_struct(png);
      end = png_create_info_struct(png);
    }
  }
  ~PngReadStructs() { png_destroy_read_struct(&png, &info, &end); }
  bool ok() const { return png && info && end; }
};

struct PngHeader {
  png_uint_32 width = 0, height = 0;
  int bit_depth = 0, color_type = 0;
  int native_type = 0;  // what PngDecoder::readHeader calls m_type
};

// Each libpng call that may longjmp runs in a function of its own, whose locals are all set
// before setjmp: the caller's C++ objects are never live across a longjmp.
bool ReadPngHeader(PngReadStructs& s, PngSource* source, PngHeader* h) {
  if (setjmp(png_jmpbuf(s.png))) return false;
  png_set_read_fn(s.png, source, ReadPngBytes);
  png_read_info(s.png, s.info);
  png_get_IHDR(s.png, s.info, &h->width, &h->height, &h->bit_depth, &h->color_type, nullptr,
               nullptr, nullptr);
  int channels = 1;
  switch (h->color_type) {
    case PNG_COLOR_TYPE_RGB:
    case PNG_COLOR_TYPE_PALETTE: {
      png_bytep trans = nullptr;
      int num_trans = 0;
      png_color_16p trans_values = nullptr;
      png_get_tRNS(s.png, s.info, &trans, &num_trans, &trans_values);
      channels = num_trans > 0 ? 4 : 3;
      break;
    }
    case PNG_COLOR_TYPE_GRAY_ALPHA:
    case PNG_COLOR_TYPE_RGB_ALPHA:
      channels = 4;
      break;
    default:
      channels = 1;
  }
  h->native_type = CV_MAKETYPE(h->bit_depth == 16 ? CV_16U : CV_8U, channels);
  return true;
}

enum class PixelsRead { kOk, kCorrupt, kLayoutMismatch };

// The decoder's status for how its pixels were read; `out` becomes the image when they were.
DecodeStatus Finish(PixelsRead read, const cv::Mat& out, cv::Mat* image) {
  switch (read) {
    case PixelsRead::kOk:
      *image = out;
      return DecodeStatus::kDecoded;
    case PixelsRead::kCorrupt:
      return DecodeStatus::kCorrupt;
    case PixelsRead::kLayoutMismatch:
      return DecodeStatus::kNotHandled;
  }
  return DecodeStatus::kNotHandled;
}

// The transformations of OpenCV's PngDecoder::readData, in its order.
PixelsRead ReadPngPixels(PngReadStructs& s, const PngHeader& h, int type, png_bytepp rows,
                         size_t row_bytes) {
  if (setjmp(png_jmpbuf(s.png))) return PixelsRead::kCorrupt;
  const int channels = CV_MAT_CN(type);
  const bool color = channels > 1;
  if (CV_MAT_DEPTH(type) == CV_8U && h.bit_depth == 16) {
    png_set_strip_16(s.png);
  } else {
    png_set_swap(s.png);  // little-endian host: PNG stores 16-bit samples big-endian
  }
  if (channels < 4) {
    png_set_strip_alpha(s.png);
  } else {
    png_set_tRNS_to_alpha(s.png);
  }
  if (h.color_type == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(s.png);
  if ((h.color_type & PNG_COLOR_MASK_COLOR) == 0 && h.bit_depth < 8) {
    png_set_expand_gray_1_2_4_to_8(s.png);
  }
  if ((h.color_type & PNG_COLOR_MASK_COLOR) != 0 && color) {
    png_set_bgr(s.png);
  } else if (color) {
    png_set_gray_to_rgb(s.png);
  } else {
    png_set_rgb_to_gray(s.png, 1, 0.299, 0.587);
  }
  png_set_interlace_handling(s.png);
  png_read_update_info(s.png, s.info);
  if (png_get_rowbytes(s.png, s.info) != row_bytes) return PixelsRead::kLayoutMismatch;
  png_read_image(s.png, rows);
  png_read_end(s.png, s.end);
  return PixelsRead::kOk;
}

DecodeStatus DecodePng(std::span<const uint8_t> bytes, int flags, cv::Mat* image) {
  if (PngHasChunksLeftToOpenCv(bytes)) return DecodeStatus::kNotHandled;
  PngReadStructs s;
  if (!s.ok()) return DecodeStatus::kNotHandled;
  PngSource source{bytes, 0};
  PngHeader header;
  if (!ReadPngHeader(s, &source, &header)) return DecodeStatus::kCorrupt;
  if (!SizeAcceptedByOpenCv(header.width, header.height)) return DecodeStatus::kNotHandled;
  const int type = TypeForFlags(header.native_type, flags);
  cv::Mat out(static_cast<int>(header.height), static_cast<int>(header.width), type);
  std::vector<png_bytep> rows(header.height);
  for (int y = 0; y < out.rows; ++y) rows[y] = out.ptr<uint8_t>(y);
  return Finish(ReadPngPixels(s, header, type, rows.data(), out.cols * out.elemSize()), out, image);
}

struct PngWriteStructs {
  png_structp png = nullptr;
  png_infop info = nullptr;
  PngWriteStructs() {
    png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, PngError, PngWarning);
    if (png) info = png_create_info_struct(png);
  }
  ~PngWriteStructs() { png_destroy_write_struct(&png, &info); }
};

void WritePngBytes(png_structp png, png_bytep data, size_t count) {
  auto* out = static_cast<std::vector<uint8_t>*>(png_get_io_ptr(png));
  out->insert(out->end(), data, data + count);
}

void FlushPng(png_structp) {}

// Settings of OpenCV's PngEncoder without parameters: the SUB filter, zlib's fastest level and the
// RLE strategy (fast, and a few percent larger than the default compression).
bool WritePng(PngWriteStructs& s, const cv::Mat& image, png_bytepp rows,
              std::vector<uint8_t>* bytes) {
  if (setjmp(png_jmpbuf(s.png))) return false;
  png_set_write_fn(s.png, bytes, WritePngBytes, FlushPng);
  png_set_filter(s.png, PNG_FILTER_TYPE_BASE, PNG_FILTER_SUB);
  png_set_compression_level(s.png, 1);
  png_set_compression_strategy(s.png, 3);  // Z_RLE
  const int channels = image.channels();
  const int color_type = channels == 1   ? PNG_COLOR_TYPE_GRAY
                         : channels == 3 ? PNG_COLOR_TYPE_RGB
                                         : PNG_COLOR_TYPE_RGB_ALPHA;
  png_set_IHDR(s.png, s.info, image.cols, image.rows, image.depth() == CV_16U ? 16 : 8, color_type,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(s.png, s.info);
  if (channels > 1) png_set_bgr(s.png);
  if (image.depth() == CV_16U) png_set_swap(s.png);
  png_write_image(s.png, rows);
  png_write_end(s.png, s.info);
  return true;
}

// ---------------------------------------------------------------------------------------------
// JPEG
// ---------------------------------------------------------------------------------------------

bool IsJpeg(std::span<const uint8_t> bytes) {
  return bytes.size() >= 3 && bytes[0] == 0xFF && bytes[1] == 0xD8 && bytes[2] == 0xFF;
}

// The orientation tag (0x0112) of IFD0 in an APP1 segment: 1 when the segment is not EXIF or
// has no orientation, nullopt when it is EXIF that this parser cannot follow.
std::optional<int> ExifOrientation(std::span<const uint8_t> app1) {
  static constexpr uint8_t kExif[6] = {'E', 'x', 'i', 'f', 0, 0};
  if (app1.size() < 6 || std::memcmp(app1.data(), kExif, 6) != 0) return 1;
  const std::span<const uint8_t> tiff = app1.subspan(6);
  if (tiff.size() < 8) return std::nullopt;
  const bool little = tiff[0] == 'I' && tiff[1] == 'I';
  if (!little && !(tiff[0] == 'M' && tiff[1] == 'M')) return std::nullopt;
  auto u16 = [&](size_t at) {
    return little ? uint32_t(tiff[at]) | uint32_t(tiff[at + 1]) << 8
                  : uint32_t(tiff[at]) << 8 | uint32_t(tiff[at + 1]);
  };
  auto u32 = [&](size_t at) {
    return little ? u16(at) | u16(at + 2) << 16 : u16(at) << 16 | u16(at + 2);
  };
  const size_t ifd = u32(4);
  if (ifd + 2 > tiff.size()) return std::nullopt;
  const size_t count = u16(ifd);
  if (ifd + 2 + 12 * count > tiff.size()) return std::nullopt;
  for (size_t i = 0; i < count; ++i) {
    const size_t entry = ifd + 2 + 12 * i;
    if (u16(entry) != 0x0112) continue;
    if (u16(entry + 2) != 3 || u32(entry + 4) != 1) return std::nullopt;  // SHORT, one value
    return static_cast<int>(u16(entry + 8));
  }
  return 1;
}

struct JpegErrors {
  jpeg_error_mgr manager;
  std::jmp_buf jump;
  bool data_ended = false;  // libjpeg met the end of the data and filled the rest of the image
};

void JpegErrorExit(j_common_ptr cinfo) {
  std::longjmp(reinterpret_cast<JpegErrors*>(cinfo->err)->jump, 1);
}

// Warnings are not printed. One is an error: a file that ends before its image does (libjpeg
// fills the rest with grey; OpenCV leaves those rows uninitialised) is reported as corrupt.
void JpegQuiet(j_common_ptr) {}

void JpegWarning(j_common_ptr cinfo, int level) {
  if (level < 0 && cinfo->err->msg_code == JWRN_JPEG_EOF) {
    reinterpret_cast<JpegErrors*>(cinfo->err)->data_ended = true;
  }
}

void InitJpegErrors(JpegErrors* errors) {
  jpeg_std_error(&errors->manager);
  errors->manager.error_exit = JpegErrorExit;
  errors->manager.output_message = JpegQuiet;
  errors->manager.emit_message = JpegWarning;
}

struct JpegDecompress {
  jpeg_decompress_struct cinfo{};
  JpegErrors errors{};
  bool created = false;
  ~JpegDecompress() {
    if (created) jpeg_destroy_decompress(&cinfo);
  }
};

enum class JpegHeader { kOk, kCorrupt, kNotHandled };

JpegHeader ReadJpegHeader(JpegDecompress& d, std::span<const uint8_t> bytes, int flags) {
  InitJpegErrors(&d.errors);
  d.cinfo.err = &d.errors.manager;
  if (setjmp(d.errors.jump)) return JpegHeader::kCorrupt;
  jpeg_create_decompress(&d.cinfo);
  d.created = true;
  jpeg_mem_src(&d.cinfo, bytes.data(), bytes.size());
  jpeg_save_markers(&d.cinfo, JPEG_APP0 + 1, 0xffff);
  jpeg_read_header(&d.cinfo, TRUE);
  // EXIF orientations other than "as stored" (OpenCV turns the image), CMYK, and Motion-JPEG
  // frames without Huffman tables (OpenCV inserts the standard ones) are left to OpenCV.
  for (jpeg_saved_marker_ptr m = d.cinfo.marker_list; m != nullptr; m = m->next) {
    if (m->marker != JPEG_APP0 + 1) continue;
    const std::span<const uint8_t> app1(m->data, m->data_length);
    if (flags != cv::IMREAD_UNCHANGED && ExifOrientation(app1).value_or(0) != 1) {
      return JpegHeader::kNotHandled;
    }
  }
  if (d.cinfo.num_components != 1 && d.cinfo.num_components != 3) return JpegHeader::kNotHandled;
  if (d.cinfo.ac_huff_tbl_ptrs[0] == nullptr && d.cinfo.ac_huff_tbl_ptrs[1] == nullptr &&
      d.cinfo.dc_huff_tbl_ptrs[0] == nullptr && d.cinfo.dc_huff_tbl_ptrs[1] == nullptr) {
    return JpegHeader::kNotHandled;
  }
  jpeg_calc_output_dimensions(&d.cinfo);
  return JpegHeader::kOk;
}

PixelsRead ReadJpegPixels(JpegDecompress& d, cv::Mat* out) {
  if (setjmp(d.errors.jump)) return PixelsRead::kCorrupt;
  const bool color = out->channels() > 1;
  d.cinfo.out_color_space = color ? JCS_EXT_BGR : JCS_GRAYSCALE;
  d.cinfo.out_color_components = color ? 3 : 1;
  jpeg_start_decompress(&d.cinfo);
  if (d.cinfo.output_width != static_cast<JDIMENSION>(out->cols) ||
      d.cinfo.output_height != static_cast<JDIMENSION>(out->rows) ||
      d.cinfo.output_components != out->channels()) {
    return PixelsRead::kLayoutMismatch;
  }
  while (d.cinfo.output_scanline < d.cinfo.output_height) {
    JSAMPROW row = out->ptr<uint8_t>(static_cast<int>(d.cinfo.output_scanline));
    jpeg_read_scanlines(&d.cinfo, &row, 1);
  }
  jpeg_finish_decompress(&d.cinfo);
  return d.errors.data_ended ? PixelsRead::kCorrupt : PixelsRead::kOk;
}

DecodeStatus DecodeJpeg(std::span<const uint8_t> bytes, int flags, cv::Mat* image) {
  JpegDecompress d;
  switch (ReadJpegHeader(d, bytes, flags)) {
    case JpegHeader::kOk:
      break;
    case JpegHeader::kCorrupt:
      return DecodeStatus::kCorrupt;
    case JpegHeader::kNotHandled:
      return DecodeStatus::kNotHandled;
  }
  if (!SizeAcceptedByOpenCv(d.cinfo.output_width, d.cinfo.output_height)) {
    return DecodeStatus::kNotHandled;
  }
  const int native = d.cinfo.num_components > 1 ? CV_8UC3 : CV_8UC1;
  cv::Mat out(static_cast<int>(d.cinfo.output_height), static_cast<int>(d.cinfo.output_width),
              TypeForFlags(native, flags));
  return Finish(ReadJpegPixels(d, &out), out, image);
}

struct JpegCompress {
  jpeg_compress_struct cinfo{};
  JpegErrors errors{};
  unsigned char* buffer = nullptr;
  unsigned long size = 0;  // NOLINT(runtime/int): jpeg_mem_dest's type
  bool created = false;
  ~JpegCompress() {
    if (created) jpeg_destroy_compress(&cinfo);
    std::free(buffer);
  }
};

bool WriteJpeg(JpegCompress& c, const cv::Mat& image, int quality) {
  InitJpegErrors(&c.errors);
  c.cinfo.err = &c.errors.manager;
  if (setjmp(c.errors.jump)) return false;
  jpeg_create_compress(&c.cinfo);
  c.created = true;
  jpeg_mem_dest(&c.cinfo, &c.buffer, &c.size);
  c.cinfo.image_width = static_cast<JDIMENSION>(image.cols);
  c.cinfo.image_height = static_cast<JDIMENSION>(image.rows);
  const bool color = image.channels() == 3;
  c.cinfo.input_components = color ? 3 : 1;
  c.cinfo.in_color_space = color ? JCS_EXT_BGR : JCS_GRAYSCALE;
  jpeg_set_defaults(&c.cinfo);
  jpeg_set_quality(&c.cinfo, quality, TRUE);
  jpeg_start_compress(&c.cinfo, TRUE);
  while (c.cinfo.next_scanline < c.cinfo.image_height) {
    JSAMPROW row =
        const_cast<uint8_t*>(image.ptr<uint8_t>(static_cast<int>(c.cinfo.next_scanline)));
    jpeg_write_scanlines(&c.cinfo, &row, 1);
  }
  jpeg_finish_compress(&c.cinfo);
  return true;
}

}  // namespace

DecodeStatus DecodePngOrJpeg(std::span<const uint8_t> bytes, int flags, cv::Mat* image) {
  if (flags != cv::IMREAD_GRAYSCALE && flags != cv::IMREAD_COLOR && flags != cv::IMREAD_UNCHANGED) {
    return DecodeStatus::kNotHandled;
  }
  if (IsPng(bytes)) return DecodePng(bytes, flags, image);
  if (IsJpeg(bytes)) return DecodeJpeg(bytes, flags, image);
  return DecodeStatus::kNotHandled;
}

bool EncodePng(const cv::Mat& image, std::vector<uint8_t>* bytes) {
  const int channels = image.channels();
  if (image.empty() || (image.depth() != CV_8U && image.depth() != CV_16U) ||
      (channels != 1 && channels != 3 && channels != 4)) {
    return false;
  }
  std::vector<png_bytep> rows(image.rows);
  for (int y = 0; y < image.rows; ++y) rows[y] = const_cast<uint8_t*>(image.ptr<uint8_t>(y));
  PngWriteStructs s;
  if (!s.png || !s.info) return false;
  bytes->clear();
  if (!WritePng(s, image, rows.data(), bytes)) {
    bytes->clear();
    return false;
  }
  return true;
}

bool EncodeJpeg(const cv::Mat& image, int quality, std::vector<uint8_t>* bytes) {
  if (image.empty() || image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3)) {
    return false;
  }
  JpegCompress c;
  if (!WriteJpeg(c, image, std::clamp(quality, 1, 100))) return false;
  bytes->assign(c.buffer, c.buffer + c.size);
  return true;
}

}  // namespace linesight::detail
