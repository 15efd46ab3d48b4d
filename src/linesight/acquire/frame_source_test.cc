#include "linesight/acquire/frame_source.h"

#include <filesystem>
#include <string>

#include <fstream>
#include <iterator>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "linesight/core/error.h"

namespace linesight {
namespace {

namespace fs = std::filesystem;

class FrameSourceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("linesight_acquire_" +
            std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // A frame whose left half is dark and right half bright, with a marker for frame `i`.
  static cv::Mat Pattern(int width, int height, int i, int value) {
    cv::Mat image(height, width, CV_8UC3, cv::Scalar::all(value));
    cv::rectangle(image, cv::Rect(4 + 6 * i, 4, 5, 5), cv::Scalar(0, 0, 255), cv::FILLED);
    return image;
  }

  std::string Write(const std::string& name, const cv::Mat& image) const {
    const fs::path path = dir_ / name;
    EXPECT_TRUE(cv::imwrite(path.string(), image));
    return path.string();
  }

  fs::path dir_;
};

TEST_F(FrameSourceTest, PairIsRepeatedWithIncreasingIndex) {
  const std::string l = Write("l.png", Pattern(33, 21, 0, 40));
  const std::string r = Write("r.png", Pattern(33, 21, 0, 200));
  auto source = OpenFrameSource("pair:" + l + "," + r);
  EXPECT_FALSE(source->IsLive());
  for (int i = 0; i < 3; ++i) {
    const auto frame = source->Read();
    ASSERT_TRUE(frame);
    EXPECT_EQ(frame->index, i);
    EXPECT_EQ(frame->left.size(), cv::Size(33, 21));
    EXPECT_EQ(frame->left.type(), CV_8UC3);
    EXPECT_EQ(frame->left.at<cv::Vec3b>(20, 30)[0], 40);
    EXPECT_EQ(frame->right.at<cv::Vec3b>(20, 30)[0], 200);
  }
}

TEST_F(FrameSourceTest, GreyImagesBecomeBgr) {
  const std::string l = Write("l.png", cv::Mat(10, 12, CV_8UC1, cv::Scalar(7)));
  const std::string r = Write("r.png", cv::Mat(10, 12, CV_8UC1, cv::Scalar(9)));
  const auto frame = OpenFrameSource("pair:" + l + "," + r)->Read();
  ASSERT_TRUE(frame);
  EXPECT_EQ(frame->right.type(), CV_8UC3);
  EXPECT_EQ(frame->right.at<cv::Vec3b>(3, 3), cv::Vec3b(9, 9, 9));
}

TEST_F(FrameSourceTest, ImageSequenceEndsOrLoops) {
  for (int i = 0; i < 3; ++i) {
    Write("left_" + std::to_string(i) + ".png", Pattern(40, 30, i, 10 + i));
    Write("right_" + std::to_string(i) + ".png", Pattern(40, 30, i, 100 + i));
  }
  const std::string spec =
      "images:" + (dir_ / "left_*.png").string() + "," + (dir_ / "right_*.png").string();
  auto source = OpenFrameSource(spec);
  for (int i = 0; i < 3; ++i) {
    const auto frame = source->Read();
    ASSERT_TRUE(frame);
    EXPECT_EQ(frame->left.at<cv::Vec3b>(29, 39)[0], 10 + i) << "sorted order, frame " << i;
    EXPECT_EQ(frame->right.at<cv::Vec3b>(29, 39)[0], 100 + i);
  }
  EXPECT_FALSE(source->Read());

  FrameSourceOptions loop;
  loop.loop = true;
  auto looping = OpenFrameSource(spec, loop);
  for (int i = 0; i < 4; ++i) ASSERT_TRUE(looping->Read());
  const auto again = looping->Read();  // frame 4 = pair 1
  ASSERT_TRUE(again);
  EXPECT_EQ(again->index, 4);
  EXPECT_EQ(again->left.at<cv::Vec3b>(29, 39)[0], 11);
}

TEST_F(FrameSourceTest, SideBySideImageIsSplit) {
  cv::Mat sbs(20, 50, CV_8UC3, cv::Scalar::all(30));
  sbs.colRange(25, 50).setTo(cv::Scalar::all(220));
  const std::string path = Write("sbs.png", sbs);
  const auto frame = OpenFrameSource("sbs:" + path)->Read();
  ASSERT_TRUE(frame);
  EXPECT_EQ(frame->left.size(), cv::Size(25, 20));
  EXPECT_EQ(frame->left.at<cv::Vec3b>(5, 24)[1], 30);
  EXPECT_EQ(frame->right.at<cv::Vec3b>(5, 0)[1], 220);

  const std::string odd = Write("odd.png", cv::Mat(20, 51, CV_8UC3, cv::Scalar::all(0)));
  try {
    OpenFrameSource("sbs:" + odd);
    FAIL() << "odd width accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("even width"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("51x20"), std::string::npos) << e.what();
  }
}

// Videos are written with OpenCV's built-in MJPEG encoder (no codec libraries needed).
void WriteVideo(const fs::path& path, const std::vector<cv::Mat>& frames) {
  cv::VideoWriter writer(path.string(), cv::CAP_OPENCV_MJPEG,
                         cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 10, frames[0].size());
  ASSERT_TRUE(writer.isOpened());
  for (const cv::Mat& f : frames) writer.write(f);
}

TEST_F(FrameSourceTest, SideBySideVideoAndTwoVideos) {
  std::vector<cv::Mat> sbs, left, right;
  for (int i = 0; i < 4; ++i) {
    cv::Mat frame(48, 128, CV_8UC3, cv::Scalar::all(40));
    frame.colRange(64, 128).setTo(cv::Scalar::all(200));
    sbs.push_back(frame);
    left.push_back(frame.colRange(0, 64).clone());
    right.push_back(frame.colRange(64, 128).clone());
  }
  WriteVideo(dir_ / "sbs.avi", sbs);
  WriteVideo(dir_ / "left.avi", left);
  WriteVideo(dir_ / "right.avi", right);

  for (const std::string& spec :
       {"sbs:" + (dir_ / "sbs.avi").string(),
        "video:" + (dir_ / "left.avi").string() + "," + (dir_ / "right.avi").string()}) {
    auto source = OpenFrameSource(spec);
    int frames = 0;
    while (const auto frame = source->Read()) {
      EXPECT_EQ(frame->index, frames);
      EXPECT_EQ(frame->left.size(), cv::Size(64, 48)) << spec;
      // MJPEG is lossy: compare with a tolerance.
      EXPECT_NEAR(cv::mean(frame->left)[0], 40, 3) << spec;
      EXPECT_NEAR(cv::mean(frame->right)[0], 200, 3) << spec;
      ++frames;
    }
    EXPECT_EQ(frames, 4) << spec;
  }

  FrameSourceOptions loop;
  loop.loop = true;
  auto looping = OpenFrameSource("sbs:" + (dir_ / "sbs.avi").string(), loop);
  for (int i = 0; i < 9; ++i) ASSERT_TRUE(looping->Read()) << "frame " << i;
}

// A video cut short (a recording stopped by a full disk, a dropped copy) ends with an error that
// names the file and how much of it was there, not as a quiet end of the run.
TEST_F(FrameSourceTest, ATruncatedVideoIsAnErrorNamingTheFile) {
  std::vector<cv::Mat> frames;
  cv::RNG rng(5);
  for (int i = 0; i < 20; ++i) {
    cv::Mat frame(48, 64, CV_8UC3);
    rng.fill(frame, cv::RNG::UNIFORM, 0, 256);  // noise: every frame a similar, large size
    frames.push_back(frame);
  }
  WriteVideo(dir_ / "whole.avi", frames);
  std::ifstream in(dir_ / "whole.avi", std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::ofstream(dir_ / "cut.avi", std::ios::binary) << bytes.substr(0, bytes.size() * 6 / 10);

  const std::string whole = (dir_ / "whole.avi").string(), cut = (dir_ / "cut.avi").string();
  auto complete = OpenFrameSource("video:" + whole + "," + whole);
  int read = 0;
  while (complete->Read()) ++read;
  EXPECT_EQ(read, 20);

  auto truncated = OpenFrameSource("video:" + whole + "," + cut);
  read = 0;
  try {
    while (truncated->Read()) ++read;
    FAIL() << "a truncated video ended quietly after " << read << " frames";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("video '" + cut + "' ended after"), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("of the 20 frames"), std::string::npos) << e.what();
  }
  EXPECT_GT(read, 5);
  EXPECT_LT(read, 20);
}

TEST_F(FrameSourceTest, SyntheticSceneCarriesItsCalibrationAndFreshNoise) {
  FrameSourceOptions options;
  options.synthetic_supersampling = 1;
  options.synthetic_obstacles = "damper:2";
  auto source = OpenFrameSource("synthetic:3", options);
  const auto calib = source->Calibration();
  ASSERT_TRUE(calib);
  const auto a = source->Read();
  const auto b = source->Read();
  ASSERT_TRUE(a && b);
  EXPECT_EQ(a->left.size(), calib->image_size);
  EXPECT_EQ(b->index, 1);
  // Same scene, new sensor noise: nearly equal images that are not identical.
  EXPECT_GT(cv::norm(a->left, b->left, cv::NORM_L1), 0);
  EXPECT_LT(cv::norm(a->left, b->left, cv::NORM_L1) / a->left.total(), 6.0);
  // Deterministic: the same seed gives the same frames.
  const auto again = OpenFrameSource("synthetic:3", options)->Read();
  ASSERT_TRUE(again);
  EXPECT_EQ(cv::norm(a->left, again->left, cv::NORM_INF), 0);
}

void ExpectError(const std::string& spec, bool usage, const std::string& fragment) {
  try {
    OpenFrameSource(spec);
    ADD_FAILURE() << spec << " was accepted";
  } catch (const UsageError& e) {
    EXPECT_TRUE(usage) << spec << ": usage error " << e.what();
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  } catch (const InputError& e) {
    EXPECT_FALSE(usage) << spec << ": input error " << e.what();
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

TEST_F(FrameSourceTest, BadSourcesGiveClearErrors) {
  const std::string l = Write("l.png", Pattern(20, 10, 0, 1));
  const std::string r = Write("r.png", Pattern(22, 10, 0, 1));
  ExpectError("webcam:0", true, "unknown scheme 'webcam'");
  ExpectError("nonsense", true, "expected SCHEME");
  ExpectError("pair:" + l, true, "two comma-separated parts");
  ExpectError("pair:" + l + ",", true, "two comma-separated parts");
  ExpectError("pair:" + l + "," + r, false, "20x10");
  ExpectError("pair:" + l + "," + (dir_ / "missing.png").string(), false, "missing.png");
  ExpectError("images:" + (dir_ / "nothing*.png").string() + "," + l, false, "matches no file");
  ExpectError("video:" + (dir_ / "a.avi").string() + "," + (dir_ / "b.avi").string(), false,
              "does not exist");
  ExpectError("v4l2:/dev/video987", false, "no such camera /dev/video987");
  ExpectError("v4l2:camera", true, "must be /dev/videoN or N");
  ExpectError("synthetic:x1", true, "seed 'x1'");
  FrameSourceOptions bad;
  bad.synthetic_supersampling = 0;
  EXPECT_THROW(OpenFrameSource("synthetic", bad), OptionError);
  // A file that exists but is no video.
  const std::string text = (dir_ / "notes.avi").string();
  {
    std::FILE* f = std::fopen(text.c_str(), "w");
    std::fputs("not a video", f);
    std::fclose(f);
  }
  ExpectError("sbs:" + text, false, "notes.avi");
}

}  // namespace
}  // namespace linesight
