// The Python module `linesight` (its compiled part, linesight._core): numpy arrays in and out for
// the matchers, rectification, calibration, ranging, point clouds and the synthetic scene. It adds
// no behaviour of its own: every function calls the library exactly as the CLI does, so a result
// computed here equals the CLI's bit for bit. Errors keep the library's messages:
// linesight.InputError / OptionError / UsageError (ValueError subclasses).
#include <cstring>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include "linesight/calib/calibration_report.h"
#include "linesight/calib/pattern.h"
#include "linesight/calib/stereo_calibrator.h"
#include "linesight/core/error.h"
#include "linesight/geometry/depth.h"
#include "linesight/geometry/point_cloud.h"
#include "linesight/io/image_io.h"
#include "linesight/io/pfm.h"
#include "linesight/io/stereo_calibration.h"
#include "linesight/line/line_obstacles.h"
#include "linesight/ranging/pipeline.h"
#include "linesight/ranging/ranging_settings.h"
#include "linesight/rectify/rectifier.h"
#include "linesight/sim/power_line_scene.h"
#include "linesight/stereo/matcher.h"

namespace py = pybind11;

namespace linesight::python {
namespace {

// ---- numpy <-> cv::Mat (always copies: the arrays and the Mats never share memory) ----

int NumpyDepth(const py::dtype& dtype, const std::string& name) {
  const char kind = dtype.kind();
  const py::ssize_t size = dtype.itemsize();
  if (kind == 'u' && size == 1) return CV_8U;
  if (kind == 'u' && size == 2) return CV_16U;
  if (kind == 'f' && size == 4) return CV_32F;
  if (kind == 'f' && size == 8) return CV_64F;
  throw InputError(
      fmt::format("{}: dtype {} is not supported (expected uint8, uint16, float32 or "
                  "float64)",
                  name, dtype.attr("name").cast<std::string>()));
}

// An (H, W) or (H, W, C) array as a Mat of its own.
cv::Mat MatFromArray(const py::array& array, const std::string& name) {
  if (array.ndim() != 2 && array.ndim() != 3) {
    throw InputError(fmt::format("{}: expected an (H, W) or (H, W, C) array, got {} dimensions",
                                 name, array.ndim()));
  }
  const int channels = array.ndim() == 3 ? static_cast<int>(array.shape(2)) : 1;
  if (channels < 1 || channels > 4) {
    throw InputError(fmt::format("{}: {} channels (expected 1 to 4)", name, channels));
  }
  const int depth = NumpyDepth(array.dtype(), name);
  const auto contiguous = py::array::ensure(array, py::array::c_style);
  const int rows = static_cast<int>(array.shape(0));
  const int cols = static_cast<int>(array.shape(1));
  cv::Mat mat(rows, cols, CV_MAKETYPE(depth, channels));
  if (!mat.empty()) std::memcpy(mat.data, contiguous.data(), mat.total() * mat.elemSize());
  return mat;
}

template <typename T>
py::array ArrayOf(const cv::Mat& mat) {
  std::vector<py::ssize_t> shape{mat.rows, mat.cols};
  if (mat.channels() > 1) shape.push_back(mat.channels());
  py::array_t<T> array(shape);
  const cv::Mat source = mat.isContinuous() ? mat : mat.clone();
  if (!source.empty()) {
    std::memcpy(array.mutable_data(), source.data, source.total() * source.elemSize());
  }
  return array;
}

py::array ArrayFromMat(const cv::Mat& mat) {
  switch (mat.depth()) {
    case CV_8U:
      return ArrayOf<uint8_t>(mat);
    case CV_16U:
      return ArrayOf<uint16_t>(mat);
    case CV_32F:
      return ArrayOf<float>(mat);
    case CV_64F:
      return ArrayOf<double>(mat);
    case CV_32S:
      return ArrayOf<int32_t>(mat);
    default:
      throw std::runtime_error(fmt::format("no numpy type for cv::Mat depth {}", mat.depth()));
  }
}

// An image for the library: uint8, (H, W) grey or (H, W, 3) BGR (OpenCV's channel order).
cv::Mat ImageFromArray(const py::array& array, const std::string& name) {
  const cv::Mat image = MatFromArray(array, name);
  if (image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3)) {
    throw InputError(fmt::format("{}: expected a uint8 (H, W) grey or (H, W, 3) BGR image", name));
  }
  return image;
}

cv::Mat DisparityFromArray(const py::array& array, const std::string& name) {
  const cv::Mat disparity = MatFromArray(array, name);
  if (disparity.type() != CV_32FC1) {
    throw InputError(fmt::format("{}: expected a float32 (H, W) disparity map", name));
  }
  return disparity;
}

// ---- JSON and settings ----

py::object FromJson(const nlohmann::json& j) {
  switch (j.type()) {
    case nlohmann::json::value_t::null:
      return py::none();
    case nlohmann::json::value_t::boolean:
      return py::bool_(j.get<bool>());
    case nlohmann::json::value_t::number_integer:
      return py::int_(j.get<int64_t>());
    case nlohmann::json::value_t::number_unsigned:
      return py::int_(j.get<uint64_t>());
    case nlohmann::json::value_t::number_float:
      return py::float_(j.get<double>());
    case nlohmann::json::value_t::string:
      return py::str(j.get<std::string>());
    case nlohmann::json::value_t::array: {
      py::list list;
      for (const auto& item : j) list.append(FromJson(item));
      return list;
    }
    default: {
      py::dict dict;
      for (const auto& [key, value] : j.items()) dict[py::str(key)] = FromJson(value);
      return dict;
    }
  }
}

// {"paths": 8, "lr_check": True} -> {"paths": "8", "lr_check": "true"}: the --param text.
std::map<std::string, std::string> SettingTexts(const py::dict& values) {
  std::map<std::string, std::string> texts;
  for (const auto& [key, value] : values) {
    std::string text;
    if (py::isinstance<py::bool_>(value)) {
      text = value.cast<bool>() ? "true" : "false";
    } else if (py::isinstance<py::int_>(value) || py::isinstance<py::float_>(value) ||
               py::isinstance<py::str>(value)) {
      text = py::str(value).cast<std::string>();
    } else {
      throw InputError(fmt::format("setting '{}': expected a bool, number or str, got {}",
                                   py::str(key).cast<std::string>(),
                                   py::str(value.get_type()).cast<std::string>()));
    }
    texts[py::str(key).cast<std::string>()] = text;
  }
  return texts;
}

cv::Rect RoiFromTuple(const std::vector<int>& roi) {
  if (roi.size() != 4) {
    throw InputError(fmt::format("roi: expected (x, y, width, height), got {} values", roi.size()));
  }
  return {roi[0], roi[1], roi[2], roi[3]};
}

// ---- the classes ----

py::dict CalibrationDict(const StereoCalibration& c) {
  py::dict d;
  d["image_size"] = py::make_tuple(c.image_size.width, c.image_size.height);
  const std::pair<const char*, const cv::Mat*> mats[] = {
      {"M1", &c.M1}, {"D1", &c.D1}, {"M2", &c.M2}, {"D2", &c.D2}, {"R", &c.R},
      {"T", &c.T},   {"E", &c.E},   {"F", &c.F},   {"R1", &c.R1}, {"R2", &c.R2},
      {"P1", &c.P1}, {"P2", &c.P2}, {"Q", &c.Q}};
  for (const auto& [name, mat] : mats) {
    d[name] = mat->empty() ? py::object(py::none()) : py::object(ArrayFromMat(*mat));
  }
  return d;
}

class Matcher {
 public:
  Matcher(const std::string& method, int min_disparity, int num_disparities, int threads,
          const py::dict& params) {
    MatcherOptions options;
    options.min_disparity = min_disparity;
    options.num_disparities = num_disparities;
    options.threads = threads;
    options.params = SettingTexts(params);
    matcher_ = CreateMatcher(method.empty() ? DefaultMatcherName() : method, options);
  }
  // (disparity, checked): float32 maps, +inf where there is no estimate.
  MatchResult Compute(const py::array& left, const py::array& right) {
    const cv::Mat l = ImageFromArray(left, "left");
    const cv::Mat r = ImageFromArray(right, "right");
    CheckSameSize(l, "left", r, "right");
    MatchResult result;
    {
      py::gil_scoped_release release;
      result = matcher_->Compute(l, r);
    }
    return result;
  }
  std::string Name() const { return matcher_->Name(); }
  py::object Settings() const { return FromJson(matcher_->Settings()); }

 private:
  std::unique_ptr<StereoMatcher> matcher_;
};

class Pipeline {
 public:
  Pipeline(const StereoCalibration& calib, const std::string& method, double min_depth_m,
           double max_depth_m, bool rectified, int threads, const py::dict& params,
           const py::dict& settings, bool line)
      : line_(line) {
    RangingPipelineOptions options;
    options.method = method;
    options.min_depth_m = min_depth_m;
    options.max_depth_m = max_depth_m;
    options.input_rectified = rectified;
    options.threads = threads;
    options.params = line ? LineMatcherParams(method, SettingTexts(params)) : SettingTexts(params);
    RangingSettingsTable().Apply("settings", SettingTexts(settings), &options);
    pipeline_.emplace(calib, options);
  }
  // Rectifies (unless rectified=True) and matches; returns the frame's maps and ranges the ROIs
  // and, with auto, the obstacles found automatically.
  py::dict Range(const py::array& left, const py::array& right,
                 const std::vector<std::vector<int>>& rois, bool automatic) {
    const cv::Mat l = ImageFromArray(left, "left");
    const cv::Mat r = ImageFromArray(right, "right");
    CheckSameSize(l, "left", r, "right");
    CheckCalibrationMatchesImage(pipeline_->rectified_calibration(), l.size(), "calibration");
    std::vector<cv::Rect> boxes;
    for (const auto& roi : rois) {
      boxes.push_back(RoiFromTuple(roi));
      CheckRoi(boxes.back(), l.size());
    }
    RangingFrame frame;
    std::vector<RangeResult> results;
    LineObstacles on_line;
    {
      py::gil_scoped_release release;
      frame = pipeline_->Process(l, r);
      results = pipeline_->RangeRois(frame, boxes);
      if (automatic) {
        for (RangeResult& result : pipeline_->RangeAuto(frame)) results.push_back(result);
      }
      if (line_) {
        on_line = FindLineObstacles(*pipeline_, frame, LineObstacleOptions{},
                                    conductor_.ok() ? &conductor_ : nullptr);
        conductor_ = on_line.conductor;
      }
    }
    py::list obstacles;
    for (size_t i = 0; i < results.size(); ++i) {
      nlohmann::json j = RangeResultToJson(results[i]);
      j["source"] = i < boxes.size() ? "roi" : "auto";
      obstacles.append(FromJson(j));
    }
    py::dict out;
    out["obstacles"] = obstacles;
    if (line_) out["line"] = FromJson(on_line.ToJson());
    out["disparity"] = ArrayFromMat(frame.disparity);
    out["checked_disparity"] = ArrayFromMat(frame.checked_disparity);
    out["left_rectified"] = ArrayFromMat(frame.left_rectified);
    out["right_rectified"] = ArrayFromMat(frame.right_rectified);
    return out;
  }
  py::object Settings() const { return FromJson(RangingChainSettings(*pipeline_)); }
  const StereoCalibration& Calibration() const { return pipeline_->rectified_calibration(); }
  void ResetConductor() { conductor_ = {}; }

 private:
  std::optional<RangingPipeline> pipeline_;
  bool line_ = false;
  ConductorModel conductor_;  // the previous frame's, which seeds the next fit
};

// (calibration, report) from per-view detections of both cameras.
py::tuple Calibrate(const calib::StereoDetections& detections, const calib::PatternSpec& spec,
                    const std::string& method) {
  calib::StereoCalibrationOptions options;
  options.method = calib::ParseMethod(method);
  options.Check();
  const calib::StereoObservations observations =
      calib::ObservationsFromDetections(detections, calib::MakeBoardGeometry(spec));
  calib::StereoCalibrationResult result;
  calib::CalibrationReport report;
  {
    py::gil_scoped_release release;
    result = calib::CalibrateStereo(observations, options);
    report = calib::EvaluateCalibration(observations, result);
  }
  return py::make_tuple(report.calibration,
                        FromJson(calib::ReportToJson(detections, result, report)));
}

calib::Detection DetectionFromCorners(const py::object& corners, const std::string& name) {
  calib::Detection detection;
  if (corners.is_none()) {
    detection.reason = "not given";
    return detection;
  }
  const cv::Mat points = MatFromArray(corners.cast<py::array>(), name);
  if (points.cols != 2 || points.channels() != 1) {
    throw InputError(fmt::format("{}: expected an (N, 2) array of corner pixels", name));
  }
  cv::Mat points64;
  points.convertTo(points64, CV_64F);
  detection.found = true;
  for (int i = 0; i < points64.rows; ++i) {
    detection.ids.push_back(i);
    detection.pixels.emplace_back(points64.at<double>(i, 0), points64.at<double>(i, 1));
  }
  return detection;
}

}  // namespace
}  // namespace linesight::python

PYBIND11_MODULE(_core, m) {
  using namespace linesight;          // NOLINT(google-build-using-namespace)
  using namespace linesight::python;  // NOLINT(google-build-using-namespace)
  m.doc() = "linesight: binocular stereo vision ranging (compiled core)";

  // Errors keep the library's messages. OptionError is an InputError.
  static py::exception<InputError> input_error(m, "InputError", PyExc_ValueError);
  static py::exception<OptionError> option_error(m, "OptionError", input_error.ptr());
  static py::exception<UsageError> usage_error(m, "UsageError", PyExc_ValueError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const OptionError& e) {
      option_error(e.what());
    } catch (const InputError& e) {
      input_error(e.what());
    } catch (const UsageError& e) {
      usage_error(e.what());
    }
  });

  // ---- images and files ----
  m.def(
      "read_image",
      [](const std::filesystem::path& path, bool grey) {
        return ArrayFromMat(ReadImage(path, grey ? ImageColor::kGray : ImageColor::kColor));
      },
      py::arg("path"), py::arg("grey") = false,
      "Reads an image as the CLI does: uint8 (H, W, 3) BGR, or (H, W) with grey=True.");
  m.def(
      "read_pfm", [](const std::filesystem::path& path) { return ArrayFromMat(ReadPfm(path)); },
      py::arg("path"), "Reads a PFM disparity map (float32, +inf = invalid).");
  m.def(
      "write_pfm",
      [](const std::filesystem::path& path, const py::array& disparity) {
        WritePfm(path, DisparityFromArray(disparity, "disparity"));
      },
      py::arg("path"), py::arg("disparity"), "Writes a float32 (H, W) map as PFM (atomically).");

  // ---- matchers ----
  m.def("matchers", &MatcherNames, "Names of the dense matchers, in the order documented.");
  m.def("default_matcher", &DefaultMatcherName, "The matcher used when none is named.");
  m.def("matcher_help", &MatcherHelp, "Every matcher with its parameters and defaults (text).");
  py::class_<Matcher>(m, "Matcher",
                      "A dense matcher of rectified pairs; params are its --param settings.")
      .def(py::init<const std::string&, int, int, int, const py::dict&>(), py::arg("method") = "",
           py::arg("min_disparity") = 0, py::arg("num_disparities") = 64, py::arg("threads") = 0,
           py::arg("params") = py::dict())
      .def(
          "compute",
          [](Matcher& matcher, const py::array& left, const py::array& right) {
            const MatchResult result = matcher.Compute(left, right);
            return py::make_tuple(ArrayFromMat(result.disparity), ArrayFromMat(result.checked));
          },
          py::arg("left"), py::arg("right"),
          "(disparity, checked): float32 (H, W) maps of the left view, +inf = no estimate; "
          "checked is the map before any filling (isgm: its SGM stage).")
      .def_property_readonly("name", &Matcher::Name)
      .def_property_readonly("settings", &Matcher::Settings, "All effective settings (dict).");
  m.def(
      "compute_disparity",
      [](const py::array& left, const py::array& right, const std::string& method,
         int min_disparity, int num_disparities, int threads, const py::dict& params) {
        Matcher matcher(method, min_disparity, num_disparities, threads, params);
        return ArrayFromMat(matcher.Compute(left, right).disparity);
      },
      py::arg("left"), py::arg("right"), py::arg("method") = "", py::arg("min_disparity") = 0,
      py::arg("num_disparities") = 64, py::arg("threads") = 0, py::arg("params") = py::dict(),
      "Dense disparity (float32, +inf = invalid) of a rectified pair, as `linesight disparity`.");

  // ---- calibration ----
  py::class_<StereoCalibration>(m, "StereoCalibration",
                                "A stereo calibration (OpenCV YAML, as `calibrate` writes).")
      .def_static("read", &ReadStereoCalibration, py::arg("path"))
      .def_static(
          "pinhole",
          [](std::pair<int, int> size, double focal_px, double cx, double cy, double baseline_m,
             double doffs_px) {
            return RectifiedPinholeCalibration({size.first, size.second}, focal_px, cx, cy,
                                               baseline_m, doffs_px);
          },
          py::arg("image_size"), py::arg("focal_px"), py::arg("cx"), py::arg("cy"),
          py::arg("baseline_m"), py::arg("doffs_px") = 0.0,
          "An already rectified pinhole pair: (width, height), focal length, principal point, "
          "baseline (m) and cx_right - cx_left (px).")
      .def(
          "write",
          [](const StereoCalibration& c, const std::filesystem::path& path) {
            WriteStereoCalibration(path, c);
          },
          py::arg("path"))
      .def_property_readonly("image_size",
                             [](const StereoCalibration& c) {
                               return std::make_pair(c.image_size.width, c.image_size.height);
                             })
      .def_property_readonly("focal_px", &StereoCalibration::RectifiedFocal)
      .def_property_readonly("baseline_m", &StereoCalibration::Baseline)
      .def("as_dict", &CalibrationDict, "Every matrix as a float64 array (None if absent).")
      .def("__repr__", [](const StereoCalibration& c) {
        return fmt::format("<StereoCalibration {}x{}, focal {:.2f} px, baseline {:.5f} m>",
                           c.image_size.width, c.image_size.height, c.RectifiedFocal(),
                           c.Baseline());
      });
  m.def(
      "detect_pattern",
      [](const py::array& image, const std::string& pattern) {
        const calib::Detection d = calib::DetectPattern(ToGray8(ImageFromArray(image, "image")),
                                                        calib::ParsePatternSpec(pattern), {});
        py::array_t<double> pixels({static_cast<py::ssize_t>(d.pixels.size()), py::ssize_t{2}});
        for (size_t i = 0; i < d.pixels.size(); ++i) {
          pixels.mutable_at(i, 0) = d.pixels[i].x;
          pixels.mutable_at(i, 1) = d.pixels[i].y;
        }
        py::dict out;
        out["found"] = d.found;
        out["reason"] = d.reason;
        out["ids"] = d.ids;
        out["pixels"] = pixels;
        return out;
      },
      py::arg("image"), py::arg("pattern"),
      "Finds a calibration pattern (e.g. 'chessboard:9x6:0.025', as `calibrate --pattern`): "
      "{found, reason, ids, pixels (N, 2)}.");
  m.def(
      "calibrate_stereo",
      [](const std::vector<py::array>& left, const std::vector<py::array>& right,
         const std::string& pattern, const std::string& method) {
        if (left.size() != right.size()) {
          throw InputError(
              fmt::format("{} left images but {} right images", left.size(), right.size()));
        }
        std::vector<cv::Mat> left_grey, right_grey;
        for (size_t i = 0; i < left.size(); ++i) {
          left_grey.push_back(ToGray8(ImageFromArray(left[i], fmt::format("left[{}]", i))));
          right_grey.push_back(ToGray8(ImageFromArray(right[i], fmt::format("right[{}]", i))));
        }
        const calib::PatternSpec spec = calib::ParsePatternSpec(pattern);
        calib::StereoDetections detections;
        {
          py::gil_scoped_release release;
          detections = calib::DetectStereoImages(left_grey, right_grey, spec, {});
        }
        return Calibrate(detections, spec, method);
      },
      py::arg("left_images"), py::arg("right_images"), py::arg("pattern"),
      py::arg("method") = "zhang",
      "Stereo calibration from image lists (uint8 arrays): (StereoCalibration, report dict), as "
      "`linesight calibrate`. method: zhang | recon | opencv.");
  m.def(
      "calibrate_stereo_from_corners",
      [](const std::vector<py::object>& left, const std::vector<py::object>& right,
         std::pair<int, int> image_size, const std::string& pattern, const std::string& method) {
        if (left.size() != right.size()) {
          throw InputError(
              fmt::format("{} left views but {} right views", left.size(), right.size()));
        }
        const calib::PatternSpec spec = calib::ParsePatternSpec(pattern);
        const size_t expected = calib::MakeBoardGeometry(spec).points.size();
        calib::StereoDetections detections;
        detections.image_size = {image_size.first, image_size.second};
        for (size_t i = 0; i < left.size(); ++i) {
          calib::PairDetection pair;
          pair.left = DetectionFromCorners(left[i], fmt::format("left[{}]", i));
          pair.right = DetectionFromCorners(right[i], fmt::format("right[{}]", i));
          for (const calib::Detection* d : {&pair.left, &pair.right}) {
            if (d->found && d->pixels.size() != expected) {
              throw InputError(fmt::format("view {}: {} corners, but pattern '{}' has {}", i,
                                           d->pixels.size(), pattern, expected));
            }
          }
          detections.pairs.push_back(std::move(pair));
        }
        return Calibrate(detections, spec, method);
      },
      py::arg("left_corners"), py::arg("right_corners"), py::arg("image_size"), py::arg("pattern"),
      py::arg("method") = "zhang",
      "Stereo calibration from detected corners: per view an (N, 2) array in the pattern's "
      "corner order, or None where the board was not seen; image_size = (width, height).");

  // ---- rectification ----
  py::class_<Rectifier>(m, "Rectifier", "Bouguet rectification maps of a calibration.")
      .def(py::init([](const StereoCalibration& calib, double alpha) {
             RectifyOptions options;
             options.alpha = alpha;
             return Rectifier(calib, options);
           }),
           py::arg("calibration"), py::arg("alpha") = 0.0)
      .def(
          "rectify",
          [](const Rectifier& rectifier, const py::array& left, const py::array& right) {
            cv::Mat l, r;
            rectifier.Rectify(ImageFromArray(left, "left"), ImageFromArray(right, "right"), &l, &r);
            return py::make_tuple(ArrayFromMat(l), ArrayFromMat(r));
          },
          py::arg("left"), py::arg("right"), "(left_rectified, right_rectified)")
      .def_property_readonly("calibration", &Rectifier::calibration,
                             "The rectified calibration (P1 P2 Q of the rectified pair).");

  // ---- ranging ----
  py::class_<Pipeline>(m, "RangingPipeline",
                       "The ranging chain of `linesight range`: rectify, match the working range, "
                       "range ROIs and/or find obstacles. settings: the --ranging keys; line: "
                       "also fit the conductor and find the typed obstacles on it (as `serve`).")
      .def(py::init<const StereoCalibration&, const std::string&, double, double, bool, int,
                    const py::dict&, const py::dict&, bool>(),
           py::arg("calibration"), py::arg("method") = "", py::arg("min_depth_m") = 0.3,
           py::arg("max_depth_m") = 6.0, py::arg("rectified") = false, py::arg("threads") = 0,
           py::arg("params") = py::dict(), py::arg("settings") = py::dict(),
           py::arg("line") = false)
      .def("range", &Pipeline::Range, py::arg("left"), py::arg("right"),
           py::arg("rois") = std::vector<std::vector<int>>{}, py::arg("auto") = false,
           "{obstacles: [dict per ROI, then per automatic obstacle], line (with line=True: the "
           "conductor model and the typed obstacles on it, nearest along the line first), "
           "disparity, checked_disparity, left_rectified, right_rectified}. rois: (x, y, w, h) "
           "in rectified left pixels. With line=True each frame's conductor fit is seeded by the "
           "previous frame's (reset_conductor() forgets it).")
      .def("reset_conductor", &Pipeline::ResetConductor)
      .def_property_readonly("settings", &Pipeline::Settings)
      .def_property_readonly("calibration", &Pipeline::Calibration);
  m.def(
      "ranging_settings",
      [] {
        py::dict out;
        for (const auto& row : RangingSettingsTable().rows()) out[py::str(row.key)] = row.doc;
        return out;
      },
      "The ranging settings (the --ranging keys) with their one-line docs.");

  // ---- 3D ----
  m.def(
      "depth_from_disparity",
      [](const py::array& disparity, const StereoCalibration& calib) {
        return ArrayFromMat(DepthFromDisparity(DisparityFromArray(disparity, "disparity"),
                                               GeometryFromCalibration(calib)));
      },
      py::arg("disparity"), py::arg("calibration"),
      "Depth along the rectified optical axis (float32 m, 0 = no depth).");
  m.def(
      "point_cloud",
      [](const py::array& disparity, const StereoCalibration& calib, const py::object& color,
         double min_depth_m, double max_depth_m, int stride) {
        CloudOptions options;
        options.min_depth_m = min_depth_m;
        options.max_depth_m = max_depth_m;
        options.stride = stride;
        const cv::Mat colour =
            color.is_none() ? cv::Mat() : ImageFromArray(color.cast<py::array>(), "color");
        const PointCloud cloud =
            MakePointCloud(DisparityFromArray(disparity, "disparity"), calib, colour, options);
        const cv::Mat points(static_cast<int>(cloud.points.size()), 3, CV_32F,
                             const_cast<cv::Point3f*>(cloud.points.data()));
        if (cloud.colors.empty()) return py::make_tuple(ArrayFromMat(points), py::none());
        const cv::Mat colors(static_cast<int>(cloud.colors.size()), 3, CV_8U,
                             const_cast<cv::Vec3b*>(cloud.colors.data()));
        return py::make_tuple(ArrayFromMat(points), ArrayFromMat(colors));
      },
      py::arg("disparity"), py::arg("calibration"), py::arg("color") = py::none(),
      py::arg("min_depth_m") = 0.0, py::arg("max_depth_m") = 0.0, py::arg("stride") = 1,
      "(points (N, 3) float32 m in the left rectified camera frame, colors (N, 3) uint8 RGB or "
      "None), as `linesight cloud`.");

  // ---- the synthetic power-line scene ----
  m.def(
      "render_scene",
      [](uint64_t seed, const std::string& obstacles, int supersampling, double noise,
         bool rectified) {
        sim::PowerLineSceneOptions options;
        options.seed = seed;
        if (!obstacles.empty()) options.obstacles = sim::ParseObstacleSpecs(obstacles);
        options.sensor.supersampling = supersampling;
        options.sensor.noise_sigma_dn = noise;
        options.render_rectified_pair = rectified;
        options.Check();
        sim::PowerLineScene scene;
        {
          py::gil_scoped_release release;
          scene = sim::RenderPowerLineScene(options);
        }
        py::dict out;
        out["left"] = ArrayFromMat(scene.left);
        out["right"] = ArrayFromMat(scene.right);
        out["calibration"] = scene.calibration;
        out["disparity"] = ArrayFromMat(scene.disparity);
        out["depth"] = ArrayFromMat(scene.depth);
        out["obstacle_mask"] = ArrayFromMat(scene.obstacle_mask);
        out["obstacles"] = FromJson(sim::ObstaclesToJson(scene.obstacles)["obstacles"]);
        if (rectified) {
          out["rectified_left"] = ArrayFromMat(scene.rectified_left);
          out["rectified_right"] = ArrayFromMat(scene.rectified_right);
        }
        return out;
      },
      py::arg("seed") = 1, py::arg("obstacles") = "", py::arg("supersampling") = 3,
      py::arg("noise") = 1.0, py::arg("rectified") = false,
      "The synthetic power-line scene with exact truth, as `linesight render`: raw BGR pair, its "
      "true calibration, rectified truth (disparity, depth, obstacle mask) and the obstacles. "
      "obstacles: 'damper:1.5,clamp:3,insulator:4.5' (empty = that default).");
}
