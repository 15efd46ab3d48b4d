#include "linesight/eval/dataset.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "linesight/core/error.h"
#include "linesight/eval/eval_test_util.h"
#include "linesight/io/pfm.h"

namespace linesight {
namespace {

namespace fs = std::filesystem;

using test::kOpenCvData;
using test::kSharedData;

bool HaveSharedData() { return fs::exists(kSharedData / "middlebury-2001-2003"); }
bool HaveAloe() { return fs::exists(kOpenCvData / "aloeGT.png"); }

#define SKIP_WITHOUT_SHARED_DATA() \
  if (!HaveSharedData())           \
  GTEST_SKIP() << "benchmark data not found at " << kSharedData << " (optional)"

// A fresh temporary folder per test, removed afterwards.
class TempDir {
 public:
  TempDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    // The process id keeps concurrent runs of this test (several build folders, ctest -j) apart.
    path_ = fs::temp_directory_path() /
            (std::string("linesight_dataset_test_") + info->test_suite_name() + "_" + info->name() +
             "_" + std::to_string(::getpid()));
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

void WriteText(const fs::path& path, const std::string& text) { std::ofstream(path) << text; }

// Range of the known ground truth (every finite pixel; Middlebury 2001's "all" leaves out a
// border).
std::pair<double, double> KnownRange(const StereoScene& scene) {
  double lo = 0, hi = 0;
  const cv::Mat known = scene.ground_truth < std::numeric_limits<float>::infinity();
  cv::minMaxLoc(scene.ground_truth, &lo, &hi, nullptr, nullptr, known);
  return {lo, hi};
}

// Mean absolute grey-level difference between the left image and the right image warped by
// `disparity_scale * gt + disparity_shift`, over `mask` pixels that land inside the right image.
double WarpError(const StereoScene& scene, const cv::Mat& mask, double disparity_scale,
                 double disparity_shift) {
  cv::Mat left, right;
  cv::cvtColor(scene.left, left, cv::COLOR_BGR2GRAY);
  cv::cvtColor(scene.right, right, cv::COLOR_BGR2GRAY);
  left.convertTo(left, CV_32F);
  right.convertTo(right, CV_32F);
  cv::Mat map_x(left.size(), CV_32F), map_y(left.size(), CV_32F);
  for (int y = 0; y < left.rows; ++y) {
    for (int x = 0; x < left.cols; ++x) {
      const float d = scene.ground_truth.at<float>(y, x);
      map_x.at<float>(y, x) = std::isfinite(d)
                                  ? static_cast<float>(x - (disparity_scale * d + disparity_shift))
                                  : -1e6f;
      map_y.at<float>(y, x) = static_cast<float>(y);
    }
  }
  cv::Mat warped;
  cv::remap(right, warped, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(-1));
  double sum = 0;
  int64_t count = 0;
  for (int y = 0; y < left.rows; ++y) {
    for (int x = 0; x < left.cols; ++x) {
      const float mx = map_x.at<float>(y, x);
      if (mask.at<uint8_t>(y, x) == 0 || mx < 0 || mx > left.cols - 1) continue;
      sum += std::abs(warped.at<float>(y, x) - left.at<float>(y, x));
      ++count;
    }
  }
  return count > 0 ? sum / static_cast<double>(count) : 1e9;
}

// ---------------------------------------------------------------------------------------------------------
// Scene discovery.

TEST(FindScenes, FindsEverySceneOfTheSharedData) {
  SKIP_WITHOUT_SHARED_DATA();
  const std::vector<SceneRef> scenes = FindScenes(kSharedData);
  std::map<std::string, std::vector<std::string>> by_set;
  for (const SceneRef& s : scenes) by_set[s.set].push_back(s.name);
  EXPECT_EQ(scenes.size(), 18u);
  using Names = std::vector<std::string>;
  EXPECT_EQ(by_set["middlebury-2001-2003"], (Names{"cones", "teddy", "tsukuba", "venus"}));
  EXPECT_EQ(by_set["middlebury-2005-2006-half"],
            (Names{"Aloe", "Art", "Baby1", "Books", "Bowling1", "Cloth1", "Dolls", "Laundry",
                   "Moebius", "Reindeer"}));
  EXPECT_EQ(by_set["middlebury-2014-quarter"], (Names{"Motorcycle"}));
  EXPECT_EQ(by_set["eth3d-two-view"], (Names{"terrace"}));
  EXPECT_EQ(by_set["kitti-2015"], (Names{"000046"}));
  EXPECT_EQ(by_set["sceneflow-sample"], (Names{"A-0032-0006"}));
  EXPECT_EQ(by_set.size(), 6u);
  EXPECT_TRUE(
      std::is_sorted(scenes.begin(), scenes.end(), [](const SceneRef& a, const SceneRef& b) {
        return std::tie(a.set, a.name) < std::tie(b.set, b.name);
      }));
  std::map<std::string, DatasetLayout> layout_of;
  for (const SceneRef& s : scenes) layout_of[s.set] = s.layout;
  EXPECT_EQ(layout_of["middlebury-2001-2003"], DatasetLayout::kMiddlebury2001);
  EXPECT_EQ(layout_of["middlebury-2005-2006-half"], DatasetLayout::kMiddlebury2005);
  EXPECT_EQ(layout_of["middlebury-2014-quarter"], DatasetLayout::kMiddlebury2014);
  EXPECT_EQ(layout_of["eth3d-two-view"], DatasetLayout::kEth3d);
  EXPECT_EQ(layout_of["kitti-2015"], DatasetLayout::kKitti2015);
  EXPECT_EQ(layout_of["sceneflow-sample"], DatasetLayout::kSceneFlow);
  EXPECT_EQ(LayoutName(DatasetLayout::kMiddlebury2001), "middlebury-2001-2003");
  EXPECT_EQ(LayoutName(DatasetLayout::kOpenCvAloe), "opencv-aloe");
}

TEST(FindScenes, RootCanBeASceneFolderOrADatasetFolder) {
  SKIP_WITHOUT_SHARED_DATA();
  const auto tsukuba = FindScenes(kSharedData / "middlebury-2001-2003" / "tsukuba");
  ASSERT_EQ(tsukuba.size(), 1u);
  EXPECT_EQ(tsukuba[0].set, "middlebury-2001-2003");
  EXPECT_EQ(tsukuba[0].name, "tsukuba");
  const auto kitti = FindScenes(kSharedData / "kitti-2015" / "training");
  ASSERT_EQ(kitti.size(), 1u);
  EXPECT_EQ(kitti[0].set, "kitti-2015");
  EXPECT_EQ(kitti[0].frame, "000046_10");
  EXPECT_EQ(FindScenes(kSharedData / "middlebury-2005-2006-half").size(), 10u);
}

TEST(FindScenes, FindsTheOpenCvAloePair) {
  if (!HaveAloe()) GTEST_SKIP() << "opencv-doc data not found at " << kOpenCvData;
  const auto scenes = FindScenes(kOpenCvData);
  ASSERT_EQ(scenes.size(), 1u);
  EXPECT_EQ(scenes[0].set, "opencv-aloe");
  EXPECT_EQ(scenes[0].name, "aloe");
  EXPECT_EQ(scenes[0].layout, DatasetLayout::kOpenCvAloe);
}

TEST(FindScenes, FolderMatchingNoLayoutHasNoScenes) {
  TempDir dir;
  fs::create_directories(dir.path() / "a" / "b");
  WriteText(dir.path() / "a" / "imL.png", "not a layout on its own");
  WriteText(dir.path() / "a" / "b" / "view1.png", "");
  EXPECT_TRUE(FindScenes(dir.path()).empty());
}

TEST(FindScenes, MissingRootIsAnInputErrorNamingIt) {
  try {
    FindScenes("/nonexistent/linesight/data");
    FAIL() << "no throw";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/linesight/data"), std::string::npos)
        << e.what();
  }
  TempDir dir;
  WriteText(dir.path() / "file.txt", "x");
  EXPECT_THROW(FindScenes(dir.path() / "file.txt"), InputError);
}

// ---------------------------------------------------------------------------------------------------------
// Every scene of the shared data, loaded once.

// Scenes are loaded on first use and kept for the other tests of the process (ctest runs each test
// in its own process, so a test loads only what it uses).
class SharedDataScenes : public ::testing::Test {
 protected:
  void SetUp() override { SKIP_WITHOUT_SHARED_DATA(); }

  static const std::vector<SceneRef>& Refs() {
    static const std::vector<SceneRef> refs = FindScenes(kSharedData);
    return refs;
  }

  static const StereoScene& Find(const std::string& name) {
    static std::map<std::string, StereoScene> loaded;
    if (auto it = loaded.find(name); it != loaded.end()) return it->second;
    for (const SceneRef& ref : Refs()) {
      if (ref.name == name) return loaded.emplace(name, LoadScene(ref)).first->second;
    }
    throw std::runtime_error("scene not found: " + name);
  }
};

TEST_F(SharedDataScenes, TsukubaGroundTruthIsMappedThroughThePalette) {
  const StereoScene& s = Find("tsukuba");
  EXPECT_EQ(s.left.size(), cv::Size(384, 288));
  const auto [lo, hi] = KnownRange(s);
  EXPECT_DOUBLE_EQ(lo, 5.0);
  EXPECT_DOUBLE_EQ(hi, 14.0);
  EXPECT_EQ(s.num_disparities, 15);  // info.txt
  EXPECT_EQ(s.min_disparity, 0);
  EXPECT_TRUE(s.masks.count("disc"));
}

TEST_F(SharedDataScenes, MiddleburyV2RangesAndScales) {
  const std::map<std::string, std::pair<double, double>> expected = {
      {"venus", {3, 19.75}}, {"teddy", {12.5, 52.75}}, {"cones", {5.5, 55}}};
  for (const auto& [name, range] : expected) {
    const auto [lo, hi] = KnownRange(Find(name));
    EXPECT_DOUBLE_EQ(lo, range.first) << name;
    EXPECT_DOUBLE_EQ(hi, range.second) << name;
  }
  // venus' info.txt says 19 disparities but its ground truth reaches 19.75: the range is raised to
  // cover it.
  EXPECT_EQ(Find("venus").num_disparities, 21);
  EXPECT_EQ(Find("teddy").num_disparities, 59);
}

TEST_F(SharedDataScenes, MotorcyclePfmAndCalibration) {
  const StereoScene& s = Find("Motorcycle");
  EXPECT_EQ(s.left.size(), cv::Size(741, 497));
  const auto [lo, hi] = KnownRange(s);
  EXPECT_NEAR(lo, 9.18, 0.005);
  EXPECT_NEAR(hi, 62.88, 0.005);
  EXPECT_DOUBLE_EQ(s.focal_px, 999.421);
  EXPECT_DOUBLE_EQ(s.doffs_px, 32.778);
  EXPECT_DOUBLE_EQ(s.baseline_m, 0.193001);
  EXPECT_EQ(s.num_disparities, 70);
  // Depth Z = B f / (d + doffs) is about 2.0..4.6 m.
  EXPECT_NEAR(s.baseline_m * s.focal_px / (hi + s.doffs_px), 2.0, 0.05);
  EXPECT_NEAR(s.baseline_m * s.focal_px / (lo + s.doffs_px), 4.6, 0.05);
}

TEST_F(SharedDataScenes, KittiSparseGroundTruth) {
  const StereoScene& s = Find("000046");
  EXPECT_EQ(s.left.size(), cv::Size(1242, 375));
  const auto [lo, hi] = KnownRange(s);
  EXPECT_NEAR(lo, 4.9, 0.05);
  EXPECT_NEAR(hi, 65.7, 0.05);
  const double known = cv::countNonZero(s.masks.at("all")) / static_cast<double>(s.left.total());
  EXPECT_NEAR(known, 0.12, 0.02);
  EXPECT_FALSE(s.masks.count("nonocc"));  // no disp_noc_0 in the sample
}

TEST_F(SharedDataScenes, Eth3dHasNoOcclusionMaskAndASensibleRange) {
  const StereoScene& s = Find("terrace");
  const auto [lo, hi] = KnownRange(s);
  EXPECT_GT(lo, 7.5);
  EXPECT_LT(hi, 17.5);
  const double known = cv::countNonZero(s.masks.at("all")) / static_cast<double>(s.left.total());
  EXPECT_NEAR(known, 0.53, 0.02);
  EXPECT_EQ(cv::countNonZero(s.masks.at("nonocc") != s.masks.at("all")), 0);
  EXPECT_DOUBLE_EQ(s.focal_px, 711.499);
  EXPECT_DOUBLE_EQ(s.baseline_m, 0.0599432);
  // calib.txt says ndisp = 713 (the image width); the range comes from the ground truth instead.
  EXPECT_EQ(s.num_disparities, 32);
}

TEST_F(SharedDataScenes, SceneFlowOcclusionIsWhite) {
  const StereoScene& s = Find("A-0032-0006");
  EXPECT_EQ(s.left.size(), cv::Size(960, 540));
  EXPECT_EQ(cv::countNonZero(s.masks.at("all")), 960 * 540);  // dense
  // 77933 of the pixels are 255 (occluded) in occlusion/left/A-0032-0006.png.
  EXPECT_EQ(cv::countNonZero(s.masks.at("nonocc")), 960 * 540 - 77933);
  // The encoding, checked against the right view's disparity: a visible pixel lands on a right
  // pixel with the same disparity, an occluded one (almost) never does.
  const cv::Mat right_gt =
      ReadPfm(kSharedData / "sceneflow-sample" / "disparity" / "right" / "A-0032-0006.pfm");
  int64_t consistent[2] = {0, 0}, total[2] = {0, 0};
  for (int y = 0; y < s.ground_truth.rows; ++y) {
    for (int x = 0; x < s.ground_truth.cols; ++x) {
      const float d = s.ground_truth.at<float>(y, x);
      const int x_right = static_cast<int>(std::floor(x - d + 0.5f));
      const int visible = s.masks.at("nonocc").at<uint8_t>(y, x) ? 1 : 0;
      ++total[visible];
      if (x_right >= 0 && x_right < s.ground_truth.cols &&
          std::abs(right_gt.at<float>(y, x_right) - d) <= 1.0f) {
        ++consistent[visible];
      }
    }
  }
  EXPECT_GT(static_cast<double>(consistent[1]) / total[1], 0.99);
  EXPECT_LT(static_cast<double>(consistent[0]) / total[0], 0.05);
}

TEST_F(SharedDataScenes, Middlebury2005HalfScaleAndDerivedNonOccludedMask) {
  for (const SceneRef& ref : Refs()) {
    if (ref.layout != DatasetLayout::kMiddlebury2005) continue;
    const StereoScene& s = Find(ref.name);
    EXPECT_EQ(s.left.rows, 555) << s.ref.name;
    const auto [lo, hi] = KnownRange(s);
    EXPECT_GT(lo, 0) << s.ref.name;
    EXPECT_LT(hi, 128) << s.ref.name;
    EXPECT_GT(s.doffs_px, 0) << s.ref.name;  // dmin.txt / 2
    // 10..24 % of the known pixels fail the left-right check (about 4..10 % because they map
    // outside the right image, the rest occluded); the mask barely changes between tolerances 0.5
    // and 4 px.
    const double nonocc = cv::countNonZero(s.masks.at("nonocc"));
    const double all = cv::countNonZero(s.masks.at("all"));
    EXPECT_GT(nonocc / all, 0.74) << s.ref.name;
    EXPECT_LT(nonocc / all, 0.92) << s.ref.name;
  }
}

void ExpectMasksInsideAll(const StereoScene& s) {
  EXPECT_EQ(s.ground_truth.type(), CV_32FC1);
  EXPECT_EQ(s.ground_truth.size(), s.left.size());
  EXPECT_EQ(s.left.type(), CV_8UC3);
  EXPECT_EQ(s.right.size(), s.left.size());
  ASSERT_TRUE(s.masks.count("all"));
  const cv::Mat& all = s.masks.at("all");
  // "all" is known ground truth only; no NaN or -inf remains.
  for (int y = 0; y < all.rows; ++y) {
    for (int x = 0; x < all.cols; ++x) {
      const float d = s.ground_truth.at<float>(y, x);
      if (all.at<uint8_t>(y, x)) {
        ASSERT_TRUE(std::isfinite(d)) << x << "," << y;
      } else if (s.ref.layout != DatasetLayout::kMiddlebury2001) {  // all.png also drops a border
        ASSERT_EQ(d, std::numeric_limits<float>::infinity()) << x << "," << y;
      }
    }
  }
  for (const auto& [region, mask] : s.masks) {
    EXPECT_EQ(mask.type(), CV_8UC1) << region;
    EXPECT_GT(cv::countNonZero(mask), 0) << region;
    EXPECT_EQ(cv::countNonZero(mask & ~all), 0) << region << " is not inside 'all'";
    EXPECT_EQ(cv::countNonZero((mask != 0) & (mask != 255)), 0) << region;
  }
  const bool expect_nonocc = s.ref.layout != DatasetLayout::kKitti2015;
  EXPECT_EQ(s.masks.count("nonocc") == 1, expect_nonocc);
  EXPECT_EQ(s.masks.count("disc") == 1, s.ref.layout == DatasetLayout::kMiddlebury2001);
}

void ExpectSearchRangeCoversTheGroundTruth(const StereoScene& s) {
  const auto [lo, hi] = KnownRange(s);
  EXPECT_LE(s.min_disparity, lo);
  EXPECT_GE(s.min_disparity + s.num_disparities - 1, hi);
  EXPECT_LT(s.num_disparities, s.left.cols / 2);
}

// Warping the right image by the ground truth must match the left image better than the same ground
// truth shifted by one pixel either way or off by 5 % in scale: catches scale, sign and offset
// errors.
void ExpectGroundTruthFitsThePair(const StereoScene& s) {
  const cv::Mat& region = s.masks.count("nonocc") ? s.masks.at("nonocc") : s.masks.at("all");
  const double at_gt = WarpError(s, region, 1.0, 0.0);
  EXPECT_LT(at_gt, WarpError(s, region, 1.0, +1.0));
  EXPECT_LT(at_gt, WarpError(s, region, 1.0, -1.0));
  EXPECT_LT(at_gt, WarpError(s, region, 1.05, 0.0));
  EXPECT_LT(at_gt, WarpError(s, region, 0.95, 0.0));
}

// Every scene: masks non-empty and inside "all", the search range covers the ground truth, and the
// ground truth fits the image pair photometrically.
TEST_F(SharedDataScenes, EverySceneIsConsistent) {
  ASSERT_EQ(Refs().size(), 18u);
  for (const SceneRef& ref : Refs()) {
    SCOPED_TRACE(ref.set + "/" + ref.name);
    const StereoScene s = LoadScene(ref);
    ExpectMasksInsideAll(s);
    ExpectSearchRangeCoversTheGroundTruth(s);
    ExpectGroundTruthFitsThePair(s);
  }
}

TEST(OpenCvAloe, FullSizeGroundTruthAtScaleOne) {
  if (!HaveAloe()) GTEST_SKIP() << "opencv-doc data not found at " << kOpenCvData;
  const auto refs = FindScenes(kOpenCvData);
  ASSERT_EQ(refs.size(), 1u);
  const StereoScene s = LoadScene(refs[0]);
  EXPECT_EQ(s.left.size(), cv::Size(1282, 1110));
  const auto [lo, hi] = KnownRange(s);
  EXPECT_DOUBLE_EQ(lo, 43.0);
  EXPECT_DOUBLE_EQ(hi, 211.0);
  // 0 marks unknown: about 3.5 % of the pixels.
  EXPECT_NEAR(1.0 - cv::countNonZero(s.masks.at("all")) / static_cast<double>(s.left.total()),
              0.0345, 0.001);
  EXPECT_EQ(s.masks.size(), 1u);
  EXPECT_GE(s.num_disparities - 1, hi);
  ExpectGroundTruthFitsThePair(s);
}

// ---------------------------------------------------------------------------------------------------------
// Broken or synthetic folders.

// Copies a (possibly read-only) data folder into a writable one.
void CopyFolder(const fs::path& from, const fs::path& to) {
  fs::create_directories(to);
  for (const auto& entry : fs::recursive_directory_iterator(from)) {
    const fs::path target = to / fs::relative(entry.path(), from);
    if (entry.is_directory()) {
      fs::create_directories(target);
    } else {
      fs::copy_file(entry.path(), target);
      fs::permissions(target, fs::perms::owner_read | fs::perms::owner_write,
                      fs::perm_options::add);
    }
  }
}

void ExpectLoadErrorNaming(const fs::path& root, const std::string& needle) {
  const auto refs = FindScenes(root);
  ASSERT_EQ(refs.size(), 1u);
  try {
    LoadScene(refs[0]);
    FAIL() << "no throw; expected an error naming " << needle;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
  }
}

TEST(LoadScene, MissingFilesAreInputErrorsNamingTheFile) {
  SKIP_WITHOUT_SHARED_DATA();
  TempDir dir;
  const fs::path tsukuba = dir.path() / "set" / "tsukuba";
  CopyFolder(kSharedData / "middlebury-2001-2003" / "tsukuba", tsukuba);
  fs::remove(tsukuba / "groundtruth.png");
  ExpectLoadErrorNaming(tsukuba, "groundtruth.png");
  CopyFolder(kSharedData / "middlebury-2001-2003" / "tsukuba", dir.path() / "t2");
  fs::remove(dir.path() / "t2" / "disc.png");
  ExpectLoadErrorNaming(dir.path() / "t2", "disc.png");

  const fs::path motorcycle = dir.path() / "moto";
  CopyFolder(kSharedData / "middlebury-2014-quarter" / "Motorcycle", motorcycle);
  fs::remove(motorcycle / "mask0nocc.png");
  ExpectLoadErrorNaming(motorcycle, "mask0nocc.png");
  CopyFolder(kSharedData / "middlebury-2014-quarter" / "Motorcycle", dir.path() / "moto2");
  fs::remove(dir.path() / "moto2" / "calib.txt");
  ExpectLoadErrorNaming(dir.path() / "moto2", "calib.txt");

  const fs::path kitti = dir.path() / "kitti" / "training";
  CopyFolder(kSharedData / "kitti-2015" / "training", kitti);
  fs::remove(kitti / "disp_occ_0" / "000046_10.png");
  ExpectLoadErrorNaming(kitti, "disp_occ_0/000046_10.png");
  fs::remove(kitti / "image_3" / "000046_10.png");
  ExpectLoadErrorNaming(kitti, "image_3/000046_10.png");

  const fs::path art = dir.path() / "art";
  CopyFolder(kSharedData / "middlebury-2005-2006-half" / "Art", art);
  fs::remove(art / "disp5.png");
  ExpectLoadErrorNaming(art, "disp5.png");
}

TEST(LoadScene, MalformedInfoAndCalibAreInputErrors) {
  SKIP_WITHOUT_SHARED_DATA();
  TempDir dir;
  const fs::path tsukuba = dir.path() / "tsukuba";
  CopyFolder(kSharedData / "middlebury-2001-2003" / "tsukuba", tsukuba);
  WriteText(tsukuba / "info.txt", "sixteen\n15\n");
  ExpectLoadErrorNaming(tsukuba, "info.txt: line 1");
  WriteText(tsukuba / "info.txt", "16\n");
  ExpectLoadErrorNaming(tsukuba, "info.txt: line 2");

  const fs::path motorcycle = dir.path() / "moto";
  CopyFolder(kSharedData / "middlebury-2014-quarter" / "Motorcycle", motorcycle);
  WriteText(motorcycle / "calib.txt", "cam0=[999 0 294; 0 999 252; 0 0 1]\ndoffs=32.7\n");
  ExpectLoadErrorNaming(motorcycle, "field 'baseline' is missing");
  WriteText(motorcycle / "calib.txt",
            "cam0=[999 0 294; 0 999 252; 0 0 1]\ndoffs=x\nbaseline=193\n");
  ExpectLoadErrorNaming(motorcycle, "'doffs=x' is not a number");
}

TEST(LoadScene, LeftAndRightOfDifferentSizesAreAnInputError) {
  SKIP_WITHOUT_SHARED_DATA();
  TempDir dir;
  const fs::path tsukuba = dir.path() / "tsukuba";
  CopyFolder(kSharedData / "middlebury-2001-2003" / "tsukuba", tsukuba);
  cv::Mat right = cv::imread((tsukuba / "imR.png").string());
  cv::imwrite((tsukuba / "imR.png").string(), right(cv::Rect(0, 0, 100, 100)));
  ExpectLoadErrorNaming(tsukuba, "imR.png");
}

// A synthetic Middlebury 2005 scene pins down the left-right rule: pixel (x, y) with left disparity
// d1 is non-occluded when the right ground truth at floor(x - d1 + 0.5) is known and within 1 px of
// d1.
TEST(LoadScene, Middlebury2005LeftRightCheckRule) {
  TempDir dir;
  const fs::path scene = dir.path() / "half" / "Synthetic";
  fs::create_directories(scene);
  const int w = 12, h = 2;
  cv::Mat view(h, w, CV_8UC3, cv::Scalar(10, 20, 30));
  cv::imwrite((scene / "view1.png").string(), view);
  cv::imwrite((scene / "view5.png").string(), view);
  // Left ground truth: 3 px everywhere (value 6), except x = 11 unknown. Row 1 uses 2.5 px (value
  // 5).
  cv::Mat disp1(h, w, CV_8UC1, cv::Scalar(6));
  disp1.at<uint8_t>(0, 11) = 0;
  disp1.row(1).setTo(5);
  // Right ground truth (row 0): 3 px, except x = 5 -> 4 px (|d1 - d5| = 1: still consistent),
  // x = 6 -> 4.5 px (1.5: occluded), x = 7 unknown.
  cv::Mat disp5(h, w, CV_8UC1, cv::Scalar(6));
  disp5.at<uint8_t>(0, 5) = 8;
  disp5.at<uint8_t>(0, 6) = 9;
  disp5.at<uint8_t>(0, 7) = 0;
  // Row 1: x - 2.5 + 0.5 -> x_r = x - 2; make x_r = 4 unknown so that only x = 6 fails.
  disp5.at<uint8_t>(1, 4) = 0;
  cv::imwrite((scene / "disp1.png").string(), disp1);
  cv::imwrite((scene / "disp5.png").string(), disp5);
  WriteText(scene / "dmin.txt", "100\n");

  const auto refs = FindScenes(dir.path());
  ASSERT_EQ(refs.size(), 1u);
  EXPECT_EQ(refs[0].set, "half");
  EXPECT_EQ(refs[0].name, "Synthetic");
  const StereoScene s = LoadScene(refs[0]);
  EXPECT_FLOAT_EQ(s.ground_truth.at<float>(0, 0), 3.0f);
  EXPECT_FLOAT_EQ(s.ground_truth.at<float>(1, 0), 2.5f);
  EXPECT_EQ(s.ground_truth.at<float>(0, 11), std::numeric_limits<float>::infinity());
  EXPECT_DOUBLE_EQ(s.doffs_px, 50.0);
  const cv::Mat& nonocc = s.masks.at("nonocc");
  // Row 0: x - 3 < 0 for x < 3 (outside); x = 8 -> x_r = 5 (4 px, ok); x = 9 -> x_r = 6 (4.5 px,
  // occluded); x = 10 -> x_r = 7 (unknown); x = 11 unknown itself.
  const std::vector<int> row0 = {0, 0, 0, 255, 255, 255, 255, 255, 255, 0, 0, 0};
  // Row 1: x_r = floor(x - 2.5 + 0.5) = x - 2: x < 2 outside, x = 6 -> x_r = 4 unknown.
  const std::vector<int> row1 = {0, 0, 255, 255, 255, 255, 0, 255, 255, 255, 255, 255};
  for (int x = 0; x < w; ++x) {
    EXPECT_EQ(nonocc.at<uint8_t>(0, x), row0[x]) << "row 0, x = " << x;
    EXPECT_EQ(nonocc.at<uint8_t>(1, x), row1[x]) << "row 1, x = " << x;
  }
  EXPECT_EQ(s.num_disparities, 16);  // ceil(1.1 * 3) + 1 = 5 -> next multiple of 16
}

}  // namespace
}  // namespace linesight
