#include "linesight/io/stereo_calibration.h"

#include <array>
#include <cmath>
#include <stdexcept>
#include <string>
#include <system_error>

#include <fmt/format.h>
#include <opencv2/core/persistence.hpp>

#include "linesight/core/atomic_file.h"
#include "linesight/core/error.h"

namespace linesight {
namespace fs = std::filesystem;

namespace {

// Largest accepted image side; anything above is certainly a corrupt file.
constexpr int kMaxImageSide = 1 << 16;

std::string NodeKind(const cv::FileNode& node) {
  if (node.isMap()) return "a map";
  if (node.isSeq()) return "a sequence";
  if (node.isString()) return "a string";
  if (node.isInt()) return "an integer";
  if (node.isReal()) return "a real number";
  return "an empty value";
}

class CalibrationDecoder {
 public:
  CalibrationDecoder(const cv::FileStorage& storage, const std::string& name)
      : fs_(storage), name_(name) {}

  cv::FileNode Field(const char* key) const {
    const cv::FileNode node = fs_[key];
    if (node.empty() || node.isNone()) throw Error(fmt::format("field '{}' is missing", key));
    return node;
  }

  int ImageSide(const char* key) const {
    const cv::FileNode node = Field(key);
    if (!node.isInt())
      throw Error(fmt::format("field '{}' must be an integer, got {}", key, NodeKind(node)));
    const int value = static_cast<int>(node);
    if (value <= 0 || value > kMaxImageSide) {
      throw Error(fmt::format("field '{}' = {} is out of range (expected 1..{})", key, value,
                              kMaxImageSide));
    }
    return value;
  }

  // Reads an !!opencv-matrix by hand (rather than through cv::read) so that the shape is checked
  // before anything is allocated and every problem is reported with the field name.
  // `allowed_shapes` lists rows x cols pairs; the first that matches wins.
  cv::Mat Matrix(const char* key, std::initializer_list<std::pair<int, int>> allowed_shapes) const {
    const cv::FileNode node = Field(key);
    std::string expected;
    for (const auto& [r, c] : allowed_shapes)
      expected += fmt::format("{}{}x{}", expected.empty() ? "" : " or ", r, c);
    if (!node.isMap()) {
      throw Error(fmt::format("field '{}' must be a {} !!opencv-matrix, got {}", key, expected,
                              NodeKind(node)));
    }
    const cv::FileNode rows_node = node["rows"], cols_node = node["cols"], dt_node = node["dt"],
                       data_node = node["data"];
    if (!rows_node.isInt() || !cols_node.isInt() || !dt_node.isString() || !data_node.isSeq()) {
      throw Error(fmt::format(
          "field '{}' must be an !!opencv-matrix with integer 'rows' and 'cols', a string "
          "'dt' and a sequence 'data'",
          key));
    }
    const int rows = static_cast<int>(rows_node), cols = static_cast<int>(cols_node);
    bool shape_ok = false;
    for (const auto& [r, c] : allowed_shapes) shape_ok = shape_ok || (rows == r && cols == c);
    if (!shape_ok)
      throw Error(
          fmt::format("field '{}' must be a {} matrix, got {}x{}", key, expected, rows, cols));
    const std::string dt = static_cast<std::string>(dt_node);
    if (dt != "d" && dt != "f") {
      throw Error(fmt::format(
          "field '{}' must hold floating-point numbers (dt 'd' or 'f'), got dt '{}'", key, dt));
    }
    if (data_node.size() != static_cast<size_t>(rows) * cols) {
      throw Error(fmt::format("field '{}' is {}x{} but its data holds {} numbers", key, rows, cols,
                              data_node.size()));
    }
    cv::Mat m(rows, cols, CV_64FC1);
    int i = 0;
    for (const cv::FileNode& value : data_node) {
      if (!value.isInt() && !value.isReal()) {
        throw Error(fmt::format("field '{}': element {} is {}, expected a number", key, i,
                                NodeKind(value)));
      }
      m.at<double>(i / cols, i % cols) = static_cast<double>(value);
      ++i;
    }
    return m;
  }

  InputError Error(const std::string& what) const {
    return InputError(fmt::format("{}: {}", name_, what));
  }

 private:
  const cv::FileStorage& fs_;
  const std::string& name_;
};

void CheckWritable(const StereoCalibration& c) {
  const std::array<std::pair<const char*, const cv::Mat*>, 13> fields = {{{"M1", &c.M1},
                                                                          {"D1", &c.D1},
                                                                          {"M2", &c.M2},
                                                                          {"D2", &c.D2},
                                                                          {"R", &c.R},
                                                                          {"T", &c.T},
                                                                          {"E", &c.E},
                                                                          {"F", &c.F},
                                                                          {"R1", &c.R1},
                                                                          {"R2", &c.R2},
                                                                          {"P1", &c.P1},
                                                                          {"P2", &c.P2},
                                                                          {"Q", &c.Q}}};
  for (const auto& [key, mat] : fields) {
    if (mat->empty() || mat->channels() != 1 ||
        (mat->depth() != CV_64F && mat->depth() != CV_32F)) {
      throw InputError(
          fmt::format("cannot write stereo calibration: matrix {} must be a non-empty "
                      "single-channel float or double matrix",
                      key));
    }
  }
  if (c.image_size.width <= 0 || c.image_size.height <= 0) {
    throw InputError(
        fmt::format("cannot write stereo calibration: image size {}x{} is not positive",
                    c.image_size.width, c.image_size.height));
  }
}

}  // namespace

StereoCalibration RectifiedPinholeCalibration(cv::Size image_size, double focal_px, double cx,
                                              double cy, double baseline_m, double doffs_px) {
  for (const double v : {focal_px, cx, cy, baseline_m, doffs_px}) {
    if (!std::isfinite(v)) {
      throw InputError(fmt::format(
          "rectified calibration: f {} px, cx {}, cy {}, baseline {} m, doffs {} px must be finite",
          focal_px, cx, cy, baseline_m, doffs_px));
    }
  }
  if (!(focal_px > 0.0) || !(baseline_m > 0.0)) {
    throw InputError(
        fmt::format("rectified calibration: focal length {} px and baseline {} m must be positive",
                    focal_px, baseline_m));
  }
  const double f = focal_px, b = baseline_m, cx_right = cx + doffs_px;
  StereoCalibration c;
  c.image_size = image_size;
  c.M1 = (cv::Mat_<double>(3, 3) << f, 0, cx, 0, f, cy, 0, 0, 1);
  c.M2 = (cv::Mat_<double>(3, 3) << f, 0, cx_right, 0, f, cy, 0, 0, 1);
  c.D1 = cv::Mat::zeros(1, 5, CV_64F);
  c.D2 = cv::Mat::zeros(1, 5, CV_64F);
  c.R = cv::Mat::eye(3, 3, CV_64F);
  c.T = (cv::Mat_<double>(3, 1) << -b, 0, 0);
  // E = [T]x R; F = K2^-T E K1^-1.
  c.E = (cv::Mat_<double>(3, 3) << 0, 0, 0, 0, 0, b, 0, -b, 0);
  c.F = c.M2.inv().t() * c.E * c.M1.inv();
  c.R1 = cv::Mat::eye(3, 3, CV_64F);
  c.R2 = cv::Mat::eye(3, 3, CV_64F);
  c.P1 = (cv::Mat_<double>(3, 4) << f, 0, cx, 0, 0, f, cy, 0, 0, 0, 1, 0);
  c.P2 = (cv::Mat_<double>(3, 4) << f, 0, cx_right, -f * b, 0, f, cy, 0, 0, 0, 1, 0);
  // OpenCV's Q (stereoRectify): [1 0 0 -cx; 0 1 0 -cy; 0 0 0 f; 0 0 -1/Tx (cx - cx')/Tx], Tx = -B.
  c.Q = (cv::Mat_<double>(4, 4) << 1, 0, 0, -cx, 0, 1, 0, -cy, 0, 0, 0, f, 0, 0, 1.0 / b,
         doffs_px / b);
  return c;
}

double StereoCalibration::RectifiedFocal() const {
  LS_CHECK_MSG(P1.type() == CV_64FC1 && P1.rows == 3 && P1.cols == 4,
               "P1 must be a 3x4 CV_64F matrix");
  return P1.at<double>(0, 0);
}

double StereoCalibration::Baseline() const {
  LS_CHECK_MSG(P2.type() == CV_64FC1 && P2.rows == 3 && P2.cols == 4,
               "P2 must be a 3x4 CV_64F matrix");
  return -P2.at<double>(0, 3) / P2.at<double>(0, 0);
}

StereoCalibration DecodeStereoCalibration(const std::string& text, const std::string& name) {
  if (text.find_first_not_of(" \t\r\n") == std::string::npos) {
    throw InputError(
        fmt::format("{}: the calibration file is empty (expected OpenCV FileStorage YAML with "
                    "image_width, image_height, M1 D1 M2 D2 R T E F R1 R2 P1 P2 Q)",
                    name));
  }
  if (text.find('\0') != std::string::npos) {
    throw InputError(fmt::format(
        "{}: not a text file (contains a NUL byte; expected OpenCV FileStorage YAML)", name));
  }
  cv::FileStorage storage;
  try {
    if (!storage.open(text, cv::FileStorage::READ | cv::FileStorage::MEMORY) ||
        !storage.isOpened()) {
      throw InputError(fmt::format("{}: cannot parse as OpenCV FileStorage YAML", name));
    }
  } catch (const cv::Exception& e) {
    throw InputError(fmt::format("{}: cannot parse as OpenCV FileStorage YAML: {}", name, e.err));
  } catch (const std::length_error& e) {
    // OpenCV 4.6's YAML parser throws this for an empty key ("   : value"); found by the fuzz test.
    throw InputError(fmt::format("{}: cannot parse as OpenCV FileStorage YAML (empty key?): {}",
                                 name, e.what()));
  }
  try {
    const CalibrationDecoder decoder(storage, name);
    StereoCalibration calib;
    calib.image_size.width = decoder.ImageSide("image_width");
    calib.image_size.height = decoder.ImageSide("image_height");
    const std::initializer_list<std::pair<int, int>> k3x3 = {{3, 3}};
    const std::initializer_list<std::pair<int, int>> kDistortion = {
        {1, 4}, {1, 5}, {1, 8}, {1, 12}, {1, 14}, {4, 1}, {5, 1}, {8, 1}, {12, 1}, {14, 1}};
    calib.M1 = decoder.Matrix("M1", k3x3);
    calib.D1 = decoder.Matrix("D1", kDistortion).reshape(1, 1);
    calib.M2 = decoder.Matrix("M2", k3x3);
    calib.D2 = decoder.Matrix("D2", kDistortion).reshape(1, 1);
    calib.R = decoder.Matrix("R", k3x3);
    calib.T = decoder.Matrix("T", {{3, 1}, {1, 3}}).reshape(1, 3);
    calib.E = decoder.Matrix("E", k3x3);
    calib.F = decoder.Matrix("F", k3x3);
    calib.R1 = decoder.Matrix("R1", k3x3);
    calib.R2 = decoder.Matrix("R2", k3x3);
    calib.P1 = decoder.Matrix("P1", {{3, 4}});
    calib.P2 = decoder.Matrix("P2", {{3, 4}});
    calib.Q = decoder.Matrix("Q", {{4, 4}});
    if (!(calib.P2.at<double>(0, 0) != 0) || !std::isfinite(calib.Baseline())) {
      throw decoder.Error("field 'P2' has a zero or non-finite focal length P2(0,0)");
    }
    return calib;
  } catch (const cv::Exception& e) {
    throw InputError(fmt::format("{}: malformed OpenCV FileStorage content: {}", name, e.err));
  }
}

std::string EncodeStereoCalibration(const StereoCalibration& calib) {
  CheckWritable(calib);
  cv::FileStorage storage(
      ".yml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_YAML);
  storage << "image_width" << calib.image_size.width;
  storage << "image_height" << calib.image_size.height;
  const auto as_double = [](const cv::Mat& m) {
    cv::Mat out;
    m.convertTo(out, CV_64F);
    return out;
  };
  storage << "M1" << as_double(calib.M1) << "D1" << as_double(calib.D1);
  storage << "M2" << as_double(calib.M2) << "D2" << as_double(calib.D2);
  storage << "R" << as_double(calib.R) << "T" << as_double(calib.T);
  storage << "E" << as_double(calib.E) << "F" << as_double(calib.F);
  storage << "R1" << as_double(calib.R1) << "R2" << as_double(calib.R2);
  storage << "P1" << as_double(calib.P1) << "P2" << as_double(calib.P2);
  storage << "Q" << as_double(calib.Q);
  return storage.releaseAndGetString();
}

StereoCalibration ReadStereoCalibration(const fs::path& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) {
    throw InputError(
        fmt::format("{}: is a folder, expected a stereo calibration YAML file", path.string()));
  }
  return DecodeStereoCalibration(ReadTextFile(path), path.string());
}

void WriteStereoCalibration(const fs::path& path, const StereoCalibration& calib) {
  WriteTextAtomic(path, EncodeStereoCalibration(calib));
}

void CheckCalibrationMatchesImage(const StereoCalibration& calib, cv::Size image_size,
                                  const fs::path& calib_path) {
  if (calib.image_size != image_size) {
    throw InputError(fmt::format("{}: the calibration is for {}x{} images but the image is {}x{}",
                                 calib_path.string(), calib.image_size.width,
                                 calib.image_size.height, image_size.width, image_size.height));
  }
}

}  // namespace linesight
