// Loaders for the public stereo benchmarks, in each benchmark's own layout (see
// ../shared/data/README.md). A loader finds scenes under a root folder by their layout; every scene
// comes out in one form.
//
// How each layout becomes a StereoScene (ground truth always CV_32FC1 px, +inf unknown; masks 255 =
// evaluate, every mask is a subset of "all" = pixels with known ground truth):
//  * Middlebury 2001/2003: gt = groundtruth.png / scale (info.txt line 1), 0 unknown; palette PNGs
//  are mapped
//    to grey. "all" = all.png == 255 and known, "nonocc" = nonocc.png == 255 and known, "disc" =
//    disc.png
//    == 255 and known (128 there marks occlusion and is not evaluated). num_disparities = info.txt
//    line 2.
//  * Middlebury 2005/2006 half: gt = disp1.png / 2, 0 unknown. "nonocc" is derived by a left-right
//  check:
//    pixel (x, y) with d1 is non-occluded when x_r = floor(x - d1 + 0.5) is inside the image, disp5
//    at (x_r, y) is known and |d1 - d5| <= kMiddlebury2005LrTolerancePx. dmin.txt (optional) is the
//    full-size disparity offset; doffs_px = dmin / 2 at half size.
//  * Middlebury 2014: gt = disp0GT.pfm (inf unknown); "nonocc" = mask0nocc.png == 255 (128
//  occluded,
//    0 unknown). calib.txt gives focal_px (cam0 f), doffs_px, baseline_m (file in mm) and ndisp.
//  * ETH3D: gt = disp0.pfm; no mask file, so "nonocc" = "all" (mask0nocc.png is used when present).
//    calib.txt as for Middlebury 2014. (ETH3D's own release, disp0GT.pfm + mask0nocc.png, loads as
//    2014.)
//  * KITTI 2015: one scene per image_2/*_10.png; gt = disp_occ_0 / 256, 0 unknown (sparse).
//  "nonocc" from
//    disp_noc_0 when that folder exists.
//  * Scene Flow: one scene per RGB_cleanpass/left/*.png; gt = disparity/left/X.pfm;
//  occlusion/left/X.png
//    (when present) holds 255 = occluded, 0 = visible, so "nonocc" = (value == 0) and known.
//  * opencv-doc Aloe: aloeL.jpg, aloeR.jpg, aloeGT.png at full size, gt = value (scale 1), 0
//  unknown.
// num_disparities: the stated ndisp (info.txt / calib.txt) when there is one smaller than half the
// image width (ETH3D states the image width, i.e. no bound), raised to ceil(max gt) + 1 if it does
// not cover the ground truth; otherwise derived from the ground truth: a multiple of 16 >= ceil(1.1
// * max gt) + 1. min_disparity is 0 unless the ground truth holds negative values.
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace linesight {

enum class DatasetLayout {
  kMiddlebury2001,  // imL.png imR.png groundtruth.png nonocc.png all.png disc.png info.txt
  kMiddlebury2005,  // view1.png view5.png disp1.png disp5.png dmin.txt (half size, scale 2)
  kMiddlebury2014,  // im0.png im1.png disp0GT.pfm mask0nocc.png calib.txt
  kEth3d,           // im0.png im1.png disp0.pfm calib.txt (no mask: every known pixel is evaluated)
  kKitti2015,       // image_2/NNNNNN_10.png image_3/... disp_occ_0/... (one scene per frame)
  kSceneFlow,       // RGB_cleanpass/{left,right}/X.png disparity/left/X.pfm occlusion/left/X.png
  kOpenCvAloe,      // opencv-doc aloeL.jpg aloeR.jpg aloeGT.png (full size, ground truth scale 1)
};

// Short stable name of a layout ("middlebury-2001-2003", "middlebury-2005-2006", "middlebury-2014",
// "eth3d", "kitti-2015", "sceneflow", "opencv-aloe").
std::string LayoutName(DatasetLayout layout);

// Tolerance of the left-right ground-truth check that derives the Middlebury 2005/2006 "nonocc"
// mask (px).
inline constexpr float kMiddlebury2005LrTolerancePx = 1.0f;

// Where a scene is and how to read it; cheap to produce (no images are read).
struct SceneRef {
  // The dataset's folder name: the parent of the scene folder ("middlebury-2001-2003"), for KITTI
  // the parent of "training"/"testing" ("kitti-2015"), for Scene Flow the folder holding
  // RGB_cleanpass
  // ("sceneflow-sample"); "opencv-aloe" for the opencv-doc pair.
  std::string set;
  std::string name;  // scene folder ("tsukuba"), KITTI frame ("000046"), Scene Flow frame, "aloe"
  DatasetLayout layout;
  std::filesystem::path
      dir;            // scene folder (for KITTI: the training folder; Scene Flow: the set folder)
  std::string frame;  // KITTI / Scene Flow frame id ("000046_10", "A-0032-0006"); else empty
};

struct StereoScene {
  SceneRef ref;
  std::filesystem::path left_path, right_path;
  cv::Mat left, right;   // 8-bit BGR as stored
  cv::Mat ground_truth;  // CV_32FC1 left disparity in px at this resolution, +inf = unknown
  // Evaluation regions, CV_8UC1, 255 = evaluate. Always "all" (= every pixel with known ground
  // truth); "nonocc" where the set defines or allows deriving occlusion; "disc" where the set has
  // it.
  std::map<std::string, cv::Mat> masks;
  int min_disparity = 0;     // search range that covers the ground truth
  int num_disparities = 64;  // (from info.txt / calib.txt ndisp / the ground truth's maximum)
  // Metric-depth calibration where the set has one (Middlebury 2014 / ETH3D calib.txt; Middlebury
  // 2005/2006 with dmin.txt: f = 3740 / 2 px, B = 160 mm, doffs = dmin / 2); 0 if unknown. Z =
  // baseline_m * focal_px / (d + doffs_px).
  double focal_px = 0, baseline_m = 0, doffs_px = 0;
};

// Finds every scene below `root` (recursively, `root` itself included), sorted by set then name.
// Throws InputError if `root` does not exist or is not a folder. A folder matching no layout is
// skipped.
std::vector<SceneRef> FindScenes(const std::filesystem::path& root);

// Reads images, ground truth and masks. Throws InputError naming the file when something is missing
// or malformed, or when the images, ground truth and masks differ in size.
StereoScene LoadScene(const SceneRef& ref);

}  // namespace linesight
