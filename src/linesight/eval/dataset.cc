#include "linesight/eval/dataset.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <sstream>
#include <system_error>
#include <tuple>

#include <fmt/format.h>
#include <opencv2/core.hpp>

#include "linesight/core/atomic_file.h"
#include "linesight/core/disparity.h"
#include "linesight/core/error.h"
#include "linesight/io/disparity_io.h"
#include "linesight/io/image_io.h"
#include "linesight/io/middlebury_calib.h"
#include "linesight/io/pfm.h"

namespace linesight {
namespace fs = std::filesystem;

namespace {

constexpr const char* kFrameSuffixKitti = "_10";

bool IsFile(const fs::path& path) {
  std::error_code ec;
  return fs::is_regular_file(path, ec);
}

bool IsDir(const fs::path& path) {
  std::error_code ec;
  return fs::is_directory(path, ec);
}

void RequireFile(const fs::path& path, const std::string& what) {
  if (!IsFile(path)) {
    throw InputError(fmt::format("{}: no such file (expected the {})", path.string(), what));
  }
}

// Folder name of `dir` made absolute ("." has no useful name).
std::string FolderName(const fs::path& dir) {
  std::error_code ec;
  fs::path abs = fs::weakly_canonical(fs::absolute(dir, ec), ec);
  if (abs.empty()) abs = dir.lexically_normal();
  if (!abs.has_filename() && abs.has_parent_path()) abs = abs.parent_path();
  return abs.filename().string();
}

std::string ParentFolderName(const fs::path& dir) {
  std::error_code ec;
  fs::path abs = fs::weakly_canonical(fs::absolute(dir, ec), ec);
  if (abs.empty()) abs = dir.lexically_normal();
  return abs.parent_path().filename().string();
}

// Sorted stems of the files in `dir` with extension `ext` whose stem ends with `suffix`.
std::vector<std::string> StemsIn(const fs::path& dir, const std::string& ext,
                                 const std::string& suffix) {
  std::vector<std::string> stems;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    if (!it->is_regular_file(ec)) continue;
    const fs::path& p = it->path();
    if (p.extension() != ext) continue;
    const std::string stem = p.stem().string();
    if (stem.size() >= suffix.size() &&
        stem.compare(stem.size() - suffix.size(), suffix.size(), suffix) == 0) {
      stems.push_back(stem);
    }
  }
  std::sort(stems.begin(), stems.end());
  return stems;
}

// Detects the per-folder layouts (one scene per folder). Returns nothing when `dir` matches none.
std::optional<DatasetLayout> DetectSceneFolder(const fs::path& dir) {
  auto has = [&](const char* name) { return IsFile(dir / name); };
  if (has("imL.png") && has("imR.png") && (has("groundtruth.png") || has("info.txt"))) {
    return DatasetLayout::kMiddlebury2001;
  }
  if (has("view1.png") && has("view5.png") && has("disp1.png"))
    return DatasetLayout::kMiddlebury2005;
  // ETH3D's own training release uses the Middlebury 2014 names (disp0GT.pfm + mask0nocc.png) and
  // loads as such; the ETH3D layout here is the one without a mask (disp0.pfm).
  if (has("im0.png") && has("im1.png") && has("disp0GT.pfm")) return DatasetLayout::kMiddlebury2014;
  if (has("im0.png") && has("im1.png") && has("disp0.pfm")) return DatasetLayout::kEth3d;
  if (has("aloeL.jpg") && has("aloeR.jpg") && has("aloeGT.png")) return DatasetLayout::kOpenCvAloe;
  return std::nullopt;
}

bool IsKittiFolder(const fs::path& dir) {
  return IsDir(dir / "image_2") && IsDir(dir / "image_3") && IsDir(dir / "disp_occ_0");
}

bool IsSceneFlowFolder(const fs::path& dir) {
  return IsDir(dir / "RGB_cleanpass" / "left") && IsDir(dir / "disparity" / "left");
}

// Adds the scenes of `dir`; returns true when `dir` is a dataset folder whose children need no
// search.
bool AddScenesOf(const fs::path& dir, std::vector<SceneRef>& scenes) {
  if (const auto layout = DetectSceneFolder(dir)) {
    SceneRef ref;
    ref.layout = *layout;
    ref.dir = dir;
    if (*layout == DatasetLayout::kOpenCvAloe) {
      ref.set = LayoutName(*layout);
      ref.name = "aloe";
    } else {
      ref.set = ParentFolderName(dir);
      ref.name = FolderName(dir);
      if (ref.set.empty()) ref.set = LayoutName(*layout);
    }
    scenes.push_back(ref);
    // The opencv-doc examples folder holds many unrelated files; the other layouts are leaf
    // folders.
    return *layout != DatasetLayout::kOpenCvAloe;
  }
  if (IsKittiFolder(dir)) {
    const std::string folder = FolderName(dir);
    std::string set =
        (folder == "training" || folder == "testing") ? ParentFolderName(dir) : folder;
    if (set.empty()) set = LayoutName(DatasetLayout::kKitti2015);
    for (const std::string& frame : StemsIn(dir / "image_2", ".png", kFrameSuffixKitti)) {
      SceneRef ref{set, frame.substr(0, frame.size() - 3), DatasetLayout::kKitti2015, dir, frame};
      scenes.push_back(ref);
    }
    return true;
  }
  if (IsSceneFlowFolder(dir)) {
    std::string set = FolderName(dir);
    if (set.empty()) set = LayoutName(DatasetLayout::kSceneFlow);
    for (const std::string& frame : StemsIn(dir / "RGB_cleanpass" / "left", ".png", "")) {
      scenes.push_back(SceneRef{set, frame, DatasetLayout::kSceneFlow, dir, frame});
    }
    return true;
  }
  return false;
}

// ---------------------------------------------------------------------------------------------------------
// Small text formats.

// Middlebury 2001/2003 info.txt: line 1 = ground-truth scale, line 2 = number of disparities.
struct Middlebury2001Info {
  double scale = 0;
  int num_disparities = 0;
};

Middlebury2001Info ReadMiddlebury2001Info(const fs::path& path) {
  RequireFile(path, "info.txt of a Middlebury 2001/2003 scene (line 1 scale, line 2 ndisp)");
  std::istringstream in(ReadTextFile(path));
  Middlebury2001Info info;
  if (!(in >> info.scale) || !std::isfinite(info.scale) || info.scale <= 0) {
    throw InputError(
        fmt::format("{}: line 1 must be the ground-truth scale, a positive number", path.string()));
  }
  if (!(in >> info.num_disparities) || info.num_disparities <= 0) {
    throw InputError(fmt::format("{}: line 2 must be the number of disparities, a positive integer",
                                 path.string()));
  }
  return info;
}

// Middlebury 2014 / ETH3D calib.txt (io/middlebury_calib.h).
MiddleburyCalib ReadCalibTxt(const fs::path& path) {
  RequireFile(
      path,
      "calib.txt (Middlebury 2014 / ETH3D layout: cam0=[f 0 cx; 0 f cy; 0 0 1], doffs, baseline)");
  return ReadMiddleburyCalib(path);
}

// Middlebury 2005/2006 dmin.txt: one integer, the full-size disparity offset.
double ReadDmin(const fs::path& path) {
  std::istringstream in(ReadTextFile(path));
  double dmin = 0;
  if (!(in >> dmin) || !std::isfinite(dmin)) {
    throw InputError(
        fmt::format("{}: expected one number (the full-size disparity offset)", path.string()));
  }
  return dmin;
}

// ---------------------------------------------------------------------------------------------------------
// Ground truth and masks.

// 8/16-bit integer image -> float px (value / scale), 0 -> unknown.
cv::Mat ScaledIntegerDisparity(const cv::Mat& values, double scale) {
  LS_CHECK(values.channels() == 1 && scale > 0);
  cv::Mat gt;
  values.convertTo(gt, CV_32F, 1.0 / scale);
  gt.setTo(kInvalidDisparity, values == 0);
  return gt;
}

// Replaces NaN and -inf by +inf so that "unknown" has one encoding.
cv::Mat NormalizeUnknown(const cv::Mat& disparity, const fs::path& path) {
  if (disparity.type() != CV_32FC1) {
    throw InputError(fmt::format("{}: expected a single-channel disparity map, got {} channels",
                                 path.string(), disparity.channels()));
  }
  cv::Mat gt = disparity.clone();
  gt.forEach<float>([](float& d, const int*) {
    if (!std::isfinite(d)) d = kInvalidDisparity;
  });
  return gt;
}

cv::Mat KnownMask(const cv::Mat& gt) {
  cv::Mat mask(gt.size(), CV_8UC1);
  for (int y = 0; y < gt.rows; ++y) {
    const float* g = gt.ptr<float>(y);
    uint8_t* m = mask.ptr<uint8_t>(y);
    for (int x = 0; x < gt.cols; ++x) m[x] = std::isfinite(g[x]) ? 255 : 0;
  }
  return mask;
}

void CheckSizeMatches(const cv::Mat& image, const fs::path& image_path, const cv::Mat& reference,
                      const fs::path& reference_path) {
  if (image.size() != reference.size()) {
    throw InputError(fmt::format("{} is {}x{} but {} is {}x{} (expected the same size)",
                                 image_path.string(), image.cols, image.rows,
                                 reference_path.string(), reference.cols, reference.rows));
  }
}

// Pixels of `mask_path` equal to `value`, restricted to known ground truth.
cv::Mat MaskWhereEquals(const fs::path& mask_path, int value, const cv::Mat& known,
                        const fs::path& gt_path) {
  const cv::Mat values = ReadImage(mask_path, ImageColor::kGray);
  CheckSizeMatches(values, mask_path, known, gt_path);
  cv::Mat mask = (values == value);
  return mask & known;
}

// Left-right check of the left ground truth against the right one (Middlebury 2005/2006).
cv::Mat LeftRightConsistentMask(const cv::Mat& gt_left, const cv::Mat& gt_right,
                                float tolerance_px) {
  cv::Mat mask(gt_left.size(), CV_8UC1, cv::Scalar(0));
  for (int y = 0; y < gt_left.rows; ++y) {
    const float* left = gt_left.ptr<float>(y);
    const float* right = gt_right.ptr<float>(y);
    uint8_t* m = mask.ptr<uint8_t>(y);
    for (int x = 0; x < gt_left.cols; ++x) {
      const float d = left[x];
      if (!std::isfinite(d)) continue;
      // Round half up explicitly (d is often a multiple of 0.5): floor(x - d + 0.5).
      const double x_right = std::floor(static_cast<double>(x) - d + 0.5);
      if (x_right < 0 || x_right >= gt_left.cols) continue;
      const float d_right = right[static_cast<int>(x_right)];
      if (std::isfinite(d_right) && std::abs(d - d_right) <= tolerance_px) m[x] = 255;
    }
  }
  return mask;
}

// Disparity search range covering the ground truth (see dataset.h).
void SetDisparityRange(StereoScene& scene, int stated_num_disparities) {
  // Over every known pixel, not only "all": Middlebury 2001's all.png leaves out a border.
  const cv::Mat known = KnownMask(scene.ground_truth);
  double min_gt = 0, max_gt = 0;
  if (cv::countNonZero(known) > 0)
    cv::minMaxLoc(scene.ground_truth, &min_gt, &max_gt, nullptr, nullptr, known);
  scene.min_disparity = min_gt < 0 ? static_cast<int>(std::floor(min_gt)) : 0;
  const int needed = static_cast<int>(std::ceil(max_gt)) + 1 - scene.min_disparity;
  if (stated_num_disparities > 0 && stated_num_disparities < scene.left.cols / 2) {
    scene.num_disparities = std::max(stated_num_disparities, needed);
  } else {
    const int with_margin = static_cast<int>(std::ceil(1.1 * (max_gt - scene.min_disparity))) + 1;
    scene.num_disparities = std::max(16, (with_margin + 15) / 16 * 16);
  }
}

void ReadPair(StereoScene& scene, const fs::path& left, const fs::path& right) {
  scene.left_path = left;
  scene.right_path = right;
  scene.left = ReadImage(left, ImageColor::kColor);
  scene.right = ReadImage(right, ImageColor::kColor);
  CheckSameSize(scene.left, left, scene.right, right);
}

void SetGroundTruth(StereoScene& scene, cv::Mat gt, const fs::path& gt_path) {
  CheckSizeMatches(gt, gt_path, scene.left, scene.left_path);
  scene.ground_truth = std::move(gt);
  scene.masks["all"] = KnownMask(scene.ground_truth);
}

// ---------------------------------------------------------------------------------------------------------
// One loader per layout.

void LoadMiddlebury2001(StereoScene& scene) {
  const fs::path& dir = scene.ref.dir;
  ReadPair(scene, dir / "imL.png", dir / "imR.png");
  const Middlebury2001Info info = ReadMiddlebury2001Info(dir / "info.txt");
  const fs::path gt_path = dir / "groundtruth.png";
  SetGroundTruth(scene, ScaledIntegerDisparity(ReadImage(gt_path, ImageColor::kGray), info.scale),
                 gt_path);
  const cv::Mat known = scene.masks["all"];
  for (const char* region : {"all", "nonocc", "disc"}) {
    const fs::path mask_path = dir / (std::string(region) + ".png");
    RequireFile(mask_path,
                fmt::format("'{}' evaluation mask of a Middlebury 2001/2003 scene", region));
    scene.masks[region] = MaskWhereEquals(mask_path, 255, known, gt_path);
  }
  SetDisparityRange(scene, info.num_disparities);
}

void LoadMiddlebury2005(StereoScene& scene) {
  const fs::path& dir = scene.ref.dir;
  ReadPair(scene, dir / "view1.png", dir / "view5.png");
  constexpr double kHalfSizeScale = 2.0;
  const fs::path gt_path = dir / "disp1.png";
  SetGroundTruth(scene,
                 ScaledIntegerDisparity(ReadImage(gt_path, ImageColor::kGray), kHalfSizeScale),
                 gt_path);
  const fs::path right_gt_path = dir / "disp5.png";
  RequireFile(right_gt_path, "right-view ground truth (needed for the non-occluded mask)");
  const cv::Mat right_gt =
      ScaledIntegerDisparity(ReadImage(right_gt_path, ImageColor::kGray), kHalfSizeScale);
  CheckSizeMatches(right_gt, right_gt_path, scene.ground_truth, gt_path);
  scene.masks["nonocc"] =
      LeftRightConsistentMask(scene.ground_truth, right_gt, kMiddlebury2005LrTolerancePx);
  if (IsFile(dir / "dmin.txt")) {
    // The 2005/2006 sets were taken with a focal length of 3740 px and a baseline of 160 mm at full
    // size, Z = baseline * f / (d + dmin) (vision.middlebury.edu/stereo/data/scenes2005/ and
    // scenes2006/); at half size f and dmin halve.
    constexpr double kFullSizeFocalPx = 3740.0, kBaselineM = 0.160;
    scene.doffs_px = ReadDmin(dir / "dmin.txt") / kHalfSizeScale;
    scene.focal_px = kFullSizeFocalPx / kHalfSizeScale;
    scene.baseline_m = kBaselineM;
  }
  SetDisparityRange(scene, 0);
}

void LoadMiddlebury2014OrEth3d(StereoScene& scene) {
  const fs::path& dir = scene.ref.dir;
  ReadPair(scene, dir / "im0.png", dir / "im1.png");
  const bool middlebury = scene.ref.layout == DatasetLayout::kMiddlebury2014;
  const fs::path gt_path = dir / (middlebury ? "disp0GT.pfm" : "disp0.pfm");
  RequireFile(gt_path, "left ground truth (PFM, inf = unknown)");
  SetGroundTruth(scene, NormalizeUnknown(ReadPfm(gt_path), gt_path), gt_path);
  const fs::path mask_path = dir / "mask0nocc.png";
  if (middlebury) {
    RequireFile(
        mask_path,
        "non-occluded mask of a Middlebury 2014 scene (255 nonocc, 128 occluded, 0 unknown)");
  }
  if (IsFile(mask_path)) {
    scene.masks["nonocc"] = MaskWhereEquals(mask_path, 255, scene.masks["all"], gt_path);
  } else {
    scene.masks["nonocc"] = scene.masks["all"].clone();  // ETH3D: no occlusion information
  }
  const MiddleburyCalib calib = ReadCalibTxt(dir / "calib.txt");
  scene.focal_px = calib.focal_px;
  scene.doffs_px = calib.doffs_px;
  scene.baseline_m = calib.baseline_mm / 1000.0;
  SetDisparityRange(scene, calib.num_disparities);
}

void LoadKitti2015(StereoScene& scene) {
  const fs::path& dir = scene.ref.dir;
  const std::string file = scene.ref.frame + ".png";
  ReadPair(scene, dir / "image_2" / file, dir / "image_3" / file);
  const fs::path gt_path = dir / "disp_occ_0" / file;
  RequireFile(gt_path, "KITTI ground truth (uint16 PNG, disparity = value / 256)");
  SetGroundTruth(scene, NormalizeUnknown(ReadKittiDisparity(gt_path), gt_path), gt_path);
  const fs::path noc_path = dir / "disp_noc_0" / file;
  if (IsFile(noc_path)) {
    const cv::Mat noc = ReadKittiDisparity(noc_path);
    CheckSizeMatches(noc, noc_path, scene.ground_truth, gt_path);
    scene.masks["nonocc"] = KnownMask(NormalizeUnknown(noc, noc_path)) & scene.masks["all"];
  }
  SetDisparityRange(scene, 0);
}

void LoadSceneFlow(StereoScene& scene) {
  const fs::path& dir = scene.ref.dir;
  const std::string& frame = scene.ref.frame;
  ReadPair(scene, dir / "RGB_cleanpass" / "left" / (frame + ".png"),
           dir / "RGB_cleanpass" / "right" / (frame + ".png"));
  const fs::path gt_path = dir / "disparity" / "left" / (frame + ".pfm");
  RequireFile(gt_path, "Scene Flow left disparity (PFM)");
  SetGroundTruth(scene, NormalizeUnknown(ReadPfm(gt_path), gt_path), gt_path);
  const fs::path occlusion_path = dir / "occlusion" / "left" / (frame + ".png");
  if (IsDir(dir / "occlusion")) {
    RequireFile(occlusion_path, "Scene Flow left occlusion mask (255 occluded, 0 visible)");
  }
  if (IsFile(occlusion_path)) {
    scene.masks["nonocc"] = MaskWhereEquals(occlusion_path, 0, scene.masks["all"], gt_path);
  }
  SetDisparityRange(scene, 0);
}

void LoadOpenCvAloe(StereoScene& scene) {
  const fs::path& dir = scene.ref.dir;
  ReadPair(scene, dir / "aloeL.jpg", dir / "aloeR.jpg");
  const fs::path gt_path = dir / "aloeGT.png";
  // Full size, scale 1 (verified: warping aloeR by the values matches aloeL best at scale 1.0), 0
  // unknown.
  SetGroundTruth(scene, ScaledIntegerDisparity(ReadImage(gt_path, ImageColor::kGray), 1.0),
                 gt_path);
  SetDisparityRange(scene, 0);
}

}  // namespace

std::string LayoutName(DatasetLayout layout) {
  switch (layout) {
    case DatasetLayout::kMiddlebury2001:
      return "middlebury-2001-2003";
    case DatasetLayout::kMiddlebury2005:
      return "middlebury-2005-2006";
    case DatasetLayout::kMiddlebury2014:
      return "middlebury-2014";
    case DatasetLayout::kEth3d:
      return "eth3d";
    case DatasetLayout::kKitti2015:
      return "kitti-2015";
    case DatasetLayout::kSceneFlow:
      return "sceneflow";
    case DatasetLayout::kOpenCvAloe:
      return "opencv-aloe";
  }
  LS_CHECK_MSG(false, "unknown DatasetLayout {}", static_cast<int>(layout));
  return {};
}

std::vector<SceneRef> FindScenes(const fs::path& root) {
  std::error_code ec;
  if (!fs::exists(root, ec)) {
    throw InputError(fmt::format("{}: no such folder (expected a folder holding stereo datasets)",
                                 root.string()));
  }
  if (!fs::is_directory(root, ec)) {
    throw InputError(
        fmt::format("{}: not a folder (expected a folder holding stereo datasets)", root.string()));
  }
  std::vector<SceneRef> scenes;
  if (!AddScenesOf(root, scenes)) {
    auto throw_if_failed = [&] {
      if (ec)
        throw InputError(fmt::format("{}: cannot list folder: {}", root.string(), ec.message()));
    };
    fs::recursive_directory_iterator it(root, fs::directory_options::skip_permission_denied, ec);
    throw_if_failed();
    for (const fs::recursive_directory_iterator end; it != end;) {
      std::error_code type_ec;
      if (it->is_directory(type_ec) && AddScenesOf(it->path(), scenes))
        it.disable_recursion_pending();
      it.increment(ec);
      throw_if_failed();
    }
  }
  std::sort(scenes.begin(), scenes.end(), [](const SceneRef& a, const SceneRef& b) {
    return std::tie(a.set, a.name, a.frame) < std::tie(b.set, b.name, b.frame);
  });
  return scenes;
}

StereoScene LoadScene(const SceneRef& ref) {
  StereoScene scene;
  scene.ref = ref;
  switch (ref.layout) {
    case DatasetLayout::kMiddlebury2001:
      LoadMiddlebury2001(scene);
      break;
    case DatasetLayout::kMiddlebury2005:
      LoadMiddlebury2005(scene);
      break;
    case DatasetLayout::kMiddlebury2014:
    case DatasetLayout::kEth3d:
      LoadMiddlebury2014OrEth3d(scene);
      break;
    case DatasetLayout::kKitti2015:
      LoadKitti2015(scene);
      break;
    case DatasetLayout::kSceneFlow:
      LoadSceneFlow(scene);
      break;
    case DatasetLayout::kOpenCvAloe:
      LoadOpenCvAloe(scene);
      break;
  }
  return scene;
}

}  // namespace linesight
