#include "linesight/io/pfm.h"

#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string_view>
#include <system_error>

#include <fmt/format.h>

#include "linesight/core/atomic_file.h"
#include "linesight/core/error.h"

namespace linesight {
namespace fs = std::filesystem;

namespace {

// Largest image we accept (width * height * channels floats): 2^28 values = 1 GiB. Guards against a
// malformed header that would make us allocate terabytes before noticing the data is missing.
constexpr std::uint64_t kMaxPfmValues = std::uint64_t{1} << 28;

bool IsPfmWhitespace(char c) { return c == ' ' || c == '\n' || c == '\r' || c == '\t'; }

// Reads the header token by token. Tokens are separated by whitespace; exactly one whitespace
// character separates the scale from the binary data (a "\r\n" pair is accepted too, see
// DecodePfm).
class HeaderReader {
 public:
  HeaderReader(std::string_view bytes, const std::string& name) : bytes_(bytes), name_(name) {}

  std::string_view NextToken(const char* what) {
    while (pos_ < bytes_.size() && IsPfmWhitespace(bytes_[pos_])) ++pos_;
    const std::size_t begin = pos_;
    // A header token is short; stop early so that garbage without whitespace is not scanned to the
    // end.
    while (pos_ < bytes_.size() && !IsPfmWhitespace(bytes_[pos_]) && pos_ - begin < 64) ++pos_;
    if (begin == pos_) {
      throw InputError(
          fmt::format("{}: PFM header ends before the {} (expected \"Pf|PF width height scale\")",
                      name_, what));
    }
    if (pos_ < bytes_.size() && !IsPfmWhitespace(bytes_[pos_])) {
      throw InputError(fmt::format(
          "{}: PFM header: the {} is not a short token followed by whitespace", name_, what));
    }
    return bytes_.substr(begin, pos_ - begin);
  }

  int NextDimension(const char* what) {
    const std::string_view token = NextToken(what);
    std::uint64_t value = 0;
    const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
    if (ec != std::errc() || end != token.data() + token.size() || token[0] == '+' ||
        token[0] == '-') {
      throw InputError(fmt::format("{}: PFM header: {} '{}' is not a positive integer", name_, what,
                                   Printable(token)));
    }
    if (value == 0 || value > kMaxPfmValues) {
      throw InputError(fmt::format("{}: PFM header: {} {} is out of range (expected 1..{})", name_,
                                   what, value, kMaxPfmValues));
    }
    return static_cast<int>(value);
  }

  double NextScale() {
    const std::string_view token = NextToken("scale");
    double value = 0;
    const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
    if (ec != std::errc() || end != token.data() + token.size()) {
      throw InputError(
          fmt::format("{}: PFM header: scale '{}' is not a number (expected e.g. -1.0; its sign "
                      "gives the byte order)",
                      name_, Printable(token)));
    }
    if (!std::isfinite(value) || value == 0) {
      throw InputError(
          fmt::format("{}: PFM header: scale {} must be a finite non-zero number (negative = "
                      "little-endian, positive = big-endian)",
                      name_, value));
    }
    return value;
  }

  // Position right after the single whitespace character that ends the header.
  std::size_t DataStart() const {
    if (pos_ >= bytes_.size()) return pos_;
    return pos_ + 1;
  }

  static std::string Printable(std::string_view token) {
    std::string out;
    for (char c : token.substr(0, 32)) out += (c >= 0x20 && c < 0x7f) ? c : '?';
    return out;
  }

 private:
  std::string_view bytes_;
  const std::string& name_;
  std::size_t pos_ = 0;
};

std::uint32_t ByteSwap(std::uint32_t v) {
  return ((v & 0xffu) << 24) | ((v & 0xff00u) << 8) | ((v >> 8) & 0xff00u) | (v >> 24);
}

}  // namespace

cv::Mat DecodePfm(const std::string& bytes, const std::string& name) {
  if (bytes.size() < 2 || bytes[0] != 'P' || (bytes[1] != 'f' && bytes[1] != 'F')) {
    throw InputError(
        fmt::format("{}: not a PFM file: it must start with \"Pf\" (grey) or \"PF\" (colour), "
                    "found \"{}\"",
                    name, HeaderReader::Printable(std::string_view(bytes).substr(0, 2))));
  }
  const int channels = bytes[1] == 'F' ? 3 : 1;
  if (bytes.size() < 3 || !IsPfmWhitespace(bytes[2])) {
    throw InputError(
        fmt::format("{}: PFM header: expected whitespace after \"{}\"", name, bytes.substr(0, 2)));
  }
  HeaderReader header(std::string_view(bytes).substr(2), name);
  const int width = header.NextDimension("width");
  const int height = header.NextDimension("height");
  const std::uint64_t values =
      std::uint64_t(width) * std::uint64_t(height) * std::uint64_t(channels);
  if (values > kMaxPfmValues) {
    throw InputError(fmt::format("{}: PFM header: {}x{}x{} values is more than the supported {}",
                                 name, width, height, channels, kMaxPfmValues));
  }
  const double scale = header.NextScale();
  const bool little_endian_file = scale < 0;

  const std::uint64_t expected = values * sizeof(float);
  std::size_t start = 2 + header.DataStart();
  std::uint64_t present = start <= bytes.size() ? bytes.size() - start : 0;
  // Some writers end the header with "\r\n"; accept it when the size then matches exactly.
  if (present == expected + 1 && bytes[start - 1] == '\r' && bytes[start] == '\n') {
    ++start;
    --present;
  }
  if (present != expected) {
    throw InputError(
        fmt::format("{}: PFM data is {}: a {}x{} {} image needs {} bytes after the header, the "
                    "file has {}",
                    name, present < expected ? "truncated" : "longer than its header says", width,
                    height, channels == 3 ? "colour" : "grey", expected, present));
  }

  cv::Mat image(height, width, CV_MAKETYPE(CV_32F, channels));
  const std::size_t row_bytes = std::size_t(width) * channels * sizeof(float);
  const bool swap = little_endian_file != (std::endian::native == std::endian::little);
  for (int file_row = 0; file_row < height; ++file_row) {
    // Rows are stored bottom-to-top.
    auto* dst = image.ptr<std::uint32_t>(height - 1 - file_row);
    std::memcpy(dst, bytes.data() + start + file_row * row_bytes, row_bytes);
    if (swap) {
      for (int i = 0; i < width * channels; ++i) dst[i] = ByteSwap(dst[i]);
    }
  }
  return image;
}

std::string EncodePfm(const cv::Mat& image) {
  if (image.empty() || (image.type() != CV_32FC1 && image.type() != CV_32FC3)) {
    throw InputError(
        fmt::format("cannot write PFM: the image must be a non-empty CV_32FC1 or CV_32FC3 matrix, "
                    "got {}x{} with type {}",
                    image.cols, image.rows, image.type()));
  }
  const int channels = image.channels();
  std::string out =
      fmt::format("{}\n{} {}\n-1.0\n", channels == 3 ? "PF" : "Pf", image.cols, image.rows);
  const std::size_t header = out.size();
  const std::size_t row_bytes = std::size_t(image.cols) * channels * sizeof(float);
  out.resize(header + row_bytes * image.rows);
  const bool swap = std::endian::native != std::endian::little;
  for (int file_row = 0; file_row < image.rows; ++file_row) {
    char* dst = out.data() + header + file_row * row_bytes;
    std::memcpy(dst, image.ptr(image.rows - 1 - file_row), row_bytes);
    if (swap) {
      for (int i = 0; i < image.cols * channels; ++i) {
        std::uint32_t v;
        std::memcpy(&v, dst + 4 * i, 4);
        v = ByteSwap(v);
        std::memcpy(dst + 4 * i, &v, 4);
      }
    }
  }
  return out;
}

cv::Mat ReadPfm(const fs::path& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) {
    throw InputError(fmt::format("{}: is a folder, expected a PFM file", path.string()));
  }
  return DecodePfm(ReadTextFile(path), path.string());
}

void WritePfm(const fs::path& path, const cv::Mat& image) {
  const std::string bytes = EncodePfm(image);  // validates before anything is written
  WriteTextAtomic(path, bytes);
}

}  // namespace linesight
