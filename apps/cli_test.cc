// End-to-end tests of the CLI contract (DESIGN.md): --help everywhere, exit codes 0 / 1 / 2, one
// clear line on stderr naming the file or value, and no output file left behind on error.
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace {
namespace fs = std::filesystem;

struct RunResult {
  int exit_code = -1;
  std::string out, err;
};

std::string Slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

class CliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("linesight_cli_" +
            std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  RunResult Run(const std::string& args) {
    const fs::path out = dir_ / "stdout.txt", err = dir_ / "stderr.txt";
    const std::string cmd = std::string(LINESIGHT_BINARY) + " " + args + " >" + out.string() +
                            " 2>" + err.string() + " </dev/null";
    const int status = std::system(cmd.c_str());
    RunResult r;
    r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    r.out = Slurp(out);
    r.err = Slurp(err);
    fs::remove(out);
    fs::remove(err);
    return r;
  }

  // A textured pair whose right view is the left shifted by 8 px.
  void WritePair(const fs::path& left, const fs::path& right, int width = 96, int height = 64) {
    cv::Mat wide(height, width + 8, CV_8UC1);
    cv::RNG rng(3);
    rng.fill(wide, cv::RNG::UNIFORM, 0, 256);
    cv::GaussianBlur(wide, wide, cv::Size(3, 3), 0.8);
    ASSERT_TRUE(cv::imwrite(left.string(), wide(cv::Rect(0, 0, width, height))));
    ASSERT_TRUE(cv::imwrite(right.string(), wide(cv::Rect(8, 0, width, height))));
  }

  size_t FileCount() const {
    return static_cast<size_t>(
        std::distance(fs::directory_iterator(dir_), fs::directory_iterator()));
  }

  fs::path dir_;
};

// Subcommand names as `linesight --help` lists them.
std::vector<std::string> ListedCommands(const std::string& help) {
  std::vector<std::string> names;
  std::istringstream in(help.substr(help.find("commands:")));
  std::string line;
  std::getline(in, line);
  while (std::getline(in, line)) {
    std::smatch m;
    if (std::regex_search(line, m, std::regex("^  ([a-z-]+) "))) names.push_back(m[1]);
  }
  return names;
}

TEST_F(CliTest, TopLevelHelpListsCommands) {
  const RunResult r = Run("--help");
  EXPECT_EQ(r.exit_code, 0);
  const auto names = ListedCommands(r.out);
  EXPECT_GE(names.size(), 2u);
  EXPECT_NE(std::find(names.begin(), names.end(), "disparity"), names.end());
}

TEST_F(CliTest, EverySubcommandHasHelp) {
  for (const std::string& name : ListedCommands(Run("--help").out)) {
    const RunResult r = Run(name + " --help");
    EXPECT_EQ(r.exit_code, 0) << name << ": " << r.err;
    EXPECT_FALSE(r.out.empty()) << name;
  }
}

TEST_F(CliTest, EveryEvalStudyHasHelp) {
  const RunResult top = Run("eval --help");
  ASSERT_EQ(top.exit_code, 0);
  std::istringstream in(top.out.substr(top.out.find("studies:")));
  std::string line;
  std::getline(in, line);
  int studies = 0;
  while (std::getline(in, line)) {
    std::smatch m;
    if (!std::regex_search(line, m, std::regex("^  ([a-z-]+) "))) continue;
    ++studies;
    const RunResult r = Run("eval " + std::string(m[1]) + " --help");
    EXPECT_EQ(r.exit_code, 0) << m[1] << ": " << r.err;
  }
  EXPECT_GE(studies, 1);
}

// The matcher registry as `disparity --help` prints it: every method, every key with its default.
TEST_F(CliTest, DisparityHelpListsEveryMethodAndItsParameters) {
  const RunResult r = Run("disparity --help");
  ASSERT_EQ(r.exit_code, 0);
  for (const char* method : {"bm", "sgbm", "sgbm-wls", "sgm", "isgm", "gc"}) {
    EXPECT_NE(r.out.find("\n  " + std::string(method) + ": "), std::string::npos) << method;
  }
  for (const char* key : {"    prefilter_cap=31 (int): ", "    mode=3way (sgbm|hh|3way|hh4): ",
                          "    sigma=1.5 (number): ", "    paths=4 (int): ",
                          "    superpixel_size=13 (int): ", "    fill_occlusions=true (bool): "}) {
    EXPECT_NE(r.out.find(key), std::string::npos) << key;
  }
}

TEST_F(CliTest, UnknownCommandIsUsageError) {
  const RunResult r = Run("frobnicate");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("unknown command 'frobnicate'"), std::string::npos);
}

TEST_F(CliTest, DisparityWritesAllOutputs) {
  WritePair(dir_ / "l.png", dir_ / "r.png");
  const RunResult r =
      Run("disparity --left " + (dir_ / "l.png").string() + " --right " +
          (dir_ / "r.png").string() + " --method sgbm --num-disp 24 --out " +
          (dir_ / "d.pfm").string() + " --color " + (dir_ / "d.png").string() + " --kitti " +
          (dir_ / "k.png").string() + " --json " + (dir_ / "r.json").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* f : {"d.pfm", "d.png", "k.png", "r.json"})
    EXPECT_TRUE(fs::exists(dir_ / f)) << f;
  EXPECT_NE(Slurp(dir_ / "r.json").find("\"density\""), std::string::npos);
}

TEST_F(CliTest, DisparityMissingFileNamesItAndWritesNothing) {
  WritePair(dir_ / "l.png", dir_ / "r.png");
  const RunResult r =
      Run("disparity --left " + (dir_ / "l.png").string() + " --right " +
          (dir_ / "nope.png").string() + " --method sgbm --out " + (dir_ / "d.pfm").string());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("nope.png"), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "d.pfm"));
}

TEST_F(CliTest, BatchProcessesAManifestResumesAndNamesAFailedPair) {
  WritePair(dir_ / "l.png", dir_ / "r.png");
  {
    std::ofstream manifest(dir_ / "pairs.txt");
    manifest
        << "# two pairs, one without its right image\nl.png r.png first\nl.png gone.png second\n";
  }
  const std::string batch = "batch --manifest " + (dir_ / "pairs.txt").string() + " --out " +
                            (dir_ / "out").string() + " --method sgbm --num-disp 24 --threads 1";
  const RunResult r = Run(batch);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("gone.png"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("1 done, 0 skipped, 1 failed"), std::string::npos) << r.err;
  EXPECT_TRUE(fs::exists(dir_ / "out" / "first.pfm"));
  EXPECT_FALSE(fs::exists(dir_ / "out" / "second.pfm"));
  EXPECT_NE(Slurp(dir_ / "out" / "summary.json").find("\"failed\": 1"), std::string::npos);
  // Once the image is there the batch resumes: the finished pair is skipped.
  fs::copy_file(dir_ / "r.png", dir_ / "gone.png");
  const RunResult again = Run(batch);
  EXPECT_EQ(again.exit_code, 0) << again.err;
  EXPECT_NE(again.err.find("1 done, 1 skipped, 0 failed"), std::string::npos) << again.err;
  EXPECT_EQ(Run(batch + " --shard 2/2").exit_code, 2);
  EXPECT_EQ(
      Run("batch --manifest " + (dir_ / "nope.txt").string() + " --out " + (dir_ / "out").string())
          .exit_code,
      1);
}

TEST_F(CliTest, DisparityUnreadableImageIsRuntimeError) {
  WritePair(dir_ / "l.png", dir_ / "r.png");
  std::ofstream(dir_ / "junk.png") << "this is not a PNG";
  const RunResult r =
      Run("disparity --left " + (dir_ / "junk.png").string() + " --right " +
          (dir_ / "r.png").string() + " --method sgbm --out " + (dir_ / "d.pfm").string());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("junk.png"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "d.pfm"));
}

TEST_F(CliTest, DisparityDifferentSizesNamesBoth) {
  WritePair(dir_ / "l.png", dir_ / "r.png", 96, 64);
  WritePair(dir_ / "l2.png", dir_ / "r2.png", 80, 64);
  const RunResult r =
      Run("disparity --left " + (dir_ / "l.png").string() + " --right " +
          (dir_ / "r2.png").string() + " --method sgbm --out " + (dir_ / "d.pfm").string());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("96x64"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("80x64"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "d.pfm"));
}

TEST_F(CliTest, UnknownMethodAndFlagAndParamAreUsageErrors) {
  WritePair(dir_ / "l.png", dir_ / "r.png");
  const std::string io = " --left " + (dir_ / "l.png").string() + " --right " +
                         (dir_ / "r.png").string() + " --out " + (dir_ / "d.pfm").string();
  RunResult r = Run("disparity --method magic" + io);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("unknown method 'magic'"), std::string::npos) << r.err;
  r = Run("disparity --method sgbm --bogus 3" + io);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--bogus"), std::string::npos) << r.err;
  r = Run("disparity --method sgbm --param nonsense=1" + io);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("unknown parameter 'nonsense' for method 'sgbm' (valid: block, "
                       "disp12_max_diff, mode, p1, p2, prefilter_cap, speckle_range, "
                       "speckle_window, uniqueness)"),
            std::string::npos)
      << r.err;
  r = Run("disparity --method sgbm --num-disp 0" + io);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("num_disparities = 0"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "d.pfm"));
  // rectify's --alpha and --calib-out only mean something with --recompute.
  for (const char* option : {"--alpha 0", "--calib-out c.yml"}) {
    r = Run(std::string("rectify --calib c.yml --left l.png --right r.png --out o ") + option);
    EXPECT_EQ(r.exit_code, 2) << option;
    EXPECT_NE(r.err.find("requires --recompute"), std::string::npos) << r.err;
  }
}

// A valid calibration (as `linesight render` writes it) and a valid 4x3 PFM, for the bad-input
// cases below.
std::string ValidCalibrationYaml() {
  return "%YAML:1.0\n---\nimage_width: 4\nimage_height: 3\n"
         "M1: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 100., 0., 2., 0., "
         "100., 1.5, 0., 0., 1. ]\n"
         "D1: !!opencv-matrix\n   rows: 1\n   cols: 5\n   dt: d\n   data: [ 0., 0., 0., 0., 0. ]\n"
         "M2: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 100., 0., 2., 0., "
         "100., 1.5, 0., 0., 1. ]\n"
         "D2: !!opencv-matrix\n   rows: 1\n   cols: 5\n   dt: d\n   data: [ 0., 0., 0., 0., 0. ]\n"
         "R: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 1., 0., 0., 0., 1., 0., "
         "0., 0., 1. ]\n"
         "T: !!opencv-matrix\n   rows: 3\n   cols: 1\n   dt: d\n   data: [ -0.1, 0., 0. ]\n"
         "E: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 0., 0., 0., 0., 0., "
         "0.1, 0., -0.1, 0. ]\n"
         "F: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 0., 0., 0., 0., 0., "
         "0.001, 0., -0.001, 0. ]\n"
         "R1: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 1., 0., 0., 0., 1., "
         "0., 0., 0., 1. ]\n"
         "R2: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 1., 0., 0., 0., 1., "
         "0., 0., 0., 1. ]\n"
         "P1: !!opencv-matrix\n   rows: 3\n   cols: 4\n   dt: d\n   data: [ 100., 0., 2., 0., 0., "
         "100., 1.5, 0., 0., 0., 1., 0. ]\n"
         "P2: !!opencv-matrix\n   rows: 3\n   cols: 4\n   dt: d\n   data: [ 100., 0., 2., -10., "
         "0., 100., 1.5, 0., 0., 0., 1., 0. ]\n"
         "Q: !!opencv-matrix\n   rows: 4\n   cols: 4\n   dt: d\n   data: [ 1., 0., 0., -2., 0., "
         "1., 0., -1.5, 0., 0., 0., 100., 0., 0., 10., 0. ]\n";
}

std::string ValidPfm() {
  std::string pfm = "Pf\n4 3\n-1.0\n";
  const float value = 5.0f;
  for (int i = 0; i < 12; ++i) pfm.append(reinterpret_cast<const char*>(&value), sizeof(value));
  return pfm;
}

TEST_F(CliTest, AcquireRecordsPairsFromAnImageSequence) {
  for (int i = 0; i < 3; ++i) {
    WritePair(dir_ / ("l" + std::to_string(i) + ".png"), dir_ / ("r" + std::to_string(i) + ".png"));
  }
  const fs::path out = dir_ / "rec";
  const RunResult r =
      Run("acquire --source 'images:" + (dir_ / "l*.png").string() + "," +
          (dir_ / "r*.png").string() + "' --frames 5 --every 2 --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("2 pairs"), std::string::npos) << r.out;  // pairs 0 and 2 of 3
  EXPECT_TRUE(fs::exists(out / "left_0000.png"));
  EXPECT_TRUE(fs::exists(out / "right_0001.png"));
  EXPECT_FALSE(fs::exists(out / "left_0002.png"));
}

TEST_F(CliTest, ServeAndAcquireNameABadSource) {
  RunResult r = Run("serve --source webcam:0 --port 0");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("unknown scheme 'webcam'"), std::string::npos) << r.err;
  r = Run("serve --source v4l2:/dev/video987 --port 0");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("no such camera /dev/video987"), std::string::npos) << r.err;
  WritePair(dir_ / "l.png", dir_ / "r.png");
  r = Run("serve --source pair:" + (dir_ / "l.png").string() + "," + (dir_ / "r.png").string() +
          " --port 0");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("give --calib"), std::string::npos) << r.err;
  r = Run("serve --source synthetic --no-auto");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--no-auto needs at least one --roi"), std::string::npos) << r.err;
  r = Run("acquire --source sbs:" + (dir_ / "missing.avi").string() + " --out " +
          (dir_ / "rec").string());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("missing.avi"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "rec"));
}

TEST_F(CliTest, CloudWorksOnValidInputs) {
  std::ofstream(dir_ / "stereo.yml") << ValidCalibrationYaml();
  std::ofstream(dir_ / "d.pfm", std::ios::binary) << ValidPfm();
  const RunResult r = Run("cloud --calib " + (dir_ / "stereo.yml").string() + " --disparity " +
                          (dir_ / "d.pfm").string() + " --out " + (dir_ / "c.ply").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(fs::exists(dir_ / "c.ply"));
}

TEST_F(CliTest, TruncatedPfmNamesFileAndWritesNothing) {
  std::ofstream(dir_ / "stereo.yml") << ValidCalibrationYaml();
  const std::string pfm = ValidPfm();
  std::ofstream(dir_ / "d.pfm", std::ios::binary) << pfm.substr(0, pfm.size() - 7);
  const RunResult r = Run("cloud --calib " + (dir_ / "stereo.yml").string() + " --disparity " +
                          (dir_ / "d.pfm").string() + " --out " + (dir_ / "c.ply").string());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("d.pfm"), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "c.ply"));
}

TEST_F(CliTest, MalformedPfmHeaderNamesFile) {
  std::ofstream(dir_ / "stereo.yml") << ValidCalibrationYaml();
  std::ofstream(dir_ / "d.pfm", std::ios::binary) << "P5\n4 3\n255\n";
  const RunResult r = Run("cloud --calib " + (dir_ / "stereo.yml").string() + " --disparity " +
                          (dir_ / "d.pfm").string() + " --out " + (dir_ / "c.ply").string());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("d.pfm"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "c.ply"));
}

TEST_F(CliTest, CalibrationMissingFieldNamesIt) {
  std::string yaml = ValidCalibrationYaml();
  yaml = yaml.substr(0, yaml.find("Q: !!opencv-matrix"));
  std::ofstream(dir_ / "stereo.yml") << yaml;
  std::ofstream(dir_ / "d.pfm", std::ios::binary) << ValidPfm();
  const RunResult r = Run("cloud --calib " + (dir_ / "stereo.yml").string() + " --disparity " +
                          (dir_ / "d.pfm").string() + " --out " + (dir_ / "c.ply").string());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("stereo.yml"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("'Q'"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "c.ply"));
}

TEST_F(CliTest, EvalStereoOnOpenCvAloe) {
  const fs::path data = LINESIGHT_OPENCV_DATA_DIR;
  if (!fs::exists(data / "aloeGT.png"))
    GTEST_SKIP() << "opencv-doc Aloe pair not installed at " << data;
  const RunResult r = Run("eval stereo --data " + data.string() + " --methods sgbm --json " +
                          (dir_ / "e.json").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("| aloe"), std::string::npos) << r.out;
  EXPECT_TRUE(fs::exists(dir_ / "e.json"));
}

TEST_F(CliTest, EvalStereoEmptyFolderIsRuntimeError) {
  const RunResult r = Run("eval stereo --data " + dir_.string() + " --methods sgbm");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("no benchmark scenes found"), std::string::npos) << r.err;
}

}  // namespace

// `range --rectified --calib C --left L --right R --roi ... --json F` on a pair that our
// power-line renderer did not make (eval plates' independent renderer, a photograph-textured box
// in front of a textured wall inside the ROI).
TEST_F(CliTest, RangeOnAnIndependentlyRenderedRectifiedPair) {
  if (!fs::exists("/usr/share/doc/opencv-doc/examples/data/baboon.jpg")) {
    GTEST_SKIP() << "opencv-doc sample images not found (scripts/install-deps.sh installs them)";
  }
  const fs::path pairs = dir_ / "pairs";
  const RunResult made =
      Run("eval plates --runs 1 --shapes box --textures baboon.jpg --distances 2.5 "
          "--supersampling 2 --save " +
          pairs.string());
  ASSERT_EQ(made.exit_code, 0) << made.err;
  const std::string scene = Slurp(pairs / "baboon_box_2.50m.json");
  std::smatch m;
  ASSERT_TRUE(std::regex_search(
      scene, m, std::regex(R"("roi":\s*\[\s*(\d+),\s*(\d+),\s*(\d+),\s*(\d+)\s*\])")))
      << scene;
  const std::string roi = m[1].str() + "," + m[2].str() + "," + m[3].str() + "," + m[4].str();
  ASSERT_TRUE(std::regex_search(scene, m, std::regex(R"("true_distance_m":\s*([0-9.eE+-]+))")));
  const double truth = std::stod(m[1].str());
  EXPECT_NEAR(truth, 2.5, 1e-6);
  const fs::path json = dir_ / "range.json";
  const RunResult r = Run("range --rectified --calib " + (pairs / "calib.yml").string() +
                          " --left " + (pairs / "baboon_box_2.50m_left.png").string() +
                          " --right " + (pairs / "baboon_box_2.50m_right.png").string() +
                          " --roi " + roi + " --json " + json.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string report = Slurp(json);
  ASSERT_TRUE(std::regex_search(report, m, std::regex(R"("distance_m":\s*([0-9.eE+-]+))")))
      << report;
  EXPECT_NEAR(std::stod(m[1].str()), truth, 0.01 * truth);
  EXPECT_NE(report.find("\"surface_check_px\""), std::string::npos) << report;
  EXPECT_NE(report.find("\"refinement\""), std::string::npos) << report;
  // Ranging settings: the surface check off, and a mode that is not a whole number refused.
  const std::string pair_args = " --rectified --calib " + (pairs / "calib.yml").string() +
                                " --left " + (pairs / "baboon_box_2.50m_left.png").string() +
                                " --right " + (pairs / "baboon_box_2.50m_right.png").string() +
                                " --roi " + roi;
  const fs::path json_off = dir_ / "range_off.json";
  const RunResult off =
      Run("range" + pair_args + " --ranging refine=0 --json " + json_off.string());
  ASSERT_EQ(off.exit_code, 0) << off.err;
  EXPECT_NE(Slurp(json_off).find("\"surface_check_px\": null"), std::string::npos)
      << Slurp(json_off);
  // `--json -`: stdout is the report alone (one JSON document), the table goes to stderr.
  const RunResult to_stdout = Run("range" + pair_args + " --json -");
  ASSERT_EQ(to_stdout.exit_code, 0) << to_stdout.err;
  nlohmann::json parsed;
  ASSERT_NO_THROW(parsed = nlohmann::json::parse(to_stdout.out)) << to_stdout.out;
  EXPECT_EQ(parsed["obstacles"].size(), 1u) << to_stdout.out;
  EXPECT_NE(to_stdout.err.find("distance_m"), std::string::npos) << to_stdout.err;
  const RunResult fraction = Run("range" + pair_args + " --ranging edge_min_rows=2.5");
  EXPECT_NE(fraction.exit_code, 0);
  EXPECT_NE(fraction.err.find("edge_min_rows=2.5"), std::string::npos) << fraction.err;
  // The fit's settings: the matched reading alone on every surface pixel; bad values are refused
  // by name.
  const RunResult old_default =
      Run("range" + pair_args +
          " --ranging refine=0 --ranging surface_gradient_ratio=0"
          " --ranging surface_interior=0 --ranging surface_min_ncc=0.9"
          " --ranging fill_rejected_holes=0 --ranging largest_mode_without_bodies=0");
  EXPECT_EQ(old_default.exit_code, 0) << old_default.err;
  // Comma-separated, as --param: the same settings in one option give the same report.
  const RunResult joined = Run("range" + pair_args +
                               " --ranging refine=0,surface_gradient_ratio=0"
                               " --ranging surface_interior=0,surface_min_ncc=0.9"
                               " --ranging fill_rejected_holes=0,largest_mode_without_bodies=0");
  EXPECT_EQ(joined.exit_code, 0) << joined.err;
  // The first line holds the matching time; the table below it must be identical.
  auto table = [](const std::string& out) { return out.substr(out.find('\n') + 1); };
  EXPECT_EQ(table(joined.out), table(old_default.out));
  const RunResult pixels = Run("range" + pair_args + " --ranging surface_min_pixels=2.5");
  EXPECT_NE(pixels.exit_code, 0);
  EXPECT_NE(pixels.err.find("surface_min_pixels=2.5"), std::string::npos) << pixels.err;
  const RunResult rows = Run("range" + pair_args + " --ranging edge_min_rows=0.5");
  EXPECT_NE(rows.exit_code, 0);
  EXPECT_NE(rows.err.find("edge_min_rows=0.5"), std::string::npos) << rows.err;
  const RunResult slope = Run("range" + pair_args + " --ranging edge_max_slope=-1");
  EXPECT_NE(slope.exit_code, 0);
  EXPECT_NE(slope.err.find("max_slope"), std::string::npos) << slope.err;
  const RunResult margin = Run("range" + pair_args + " --ranging silhouette_margin_x_px=1e300");
  EXPECT_NE(margin.exit_code, 0);
  EXPECT_NE(margin.err.find("silhouette_margin_x_px=1e300"), std::string::npos) << margin.err;
  const RunResult ratio = Run("range" + pair_args + " --ranging surface_gradient_ratio=-1");
  EXPECT_NE(ratio.exit_code, 0);
  EXPECT_NE(ratio.err.find("gradient_ratio"), std::string::npos) << ratio.err;
  // The same calibration with a pair of another size is an error naming the file.
  const RunResult bad =
      Run("range --rectified --calib " + (pairs / "calib.yml").string() + " --left " +
          (pairs / "baboon_box_2.50m_left.png").string() + " --right " +
          (pairs / "baboon_box_2.50m_left.png").string() + " --roi 5000,0,10,10");
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.err.find("5000"), std::string::npos) << bad.err;
}
