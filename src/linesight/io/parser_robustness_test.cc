// Deterministic mutation testing of the parsers for untrusted files (PFM, calibration YAML). This
// is the always-on companion of the libFuzzer targets (pfm_fuzz.cc, calibration_yaml_fuzz.cc): it
// runs in every CI build, including the ASan+UBSan one, and requires that every mutated input
// either decodes or throws InputError — never crashes, never throws anything else.
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

#include "linesight/core/error.h"
#include "linesight/io/pfm.h"
#include "linesight/io/stereo_calibration.h"

namespace linesight {
namespace {

class Mutator {
 public:
  explicit Mutator(std::uint64_t seed) : rng_(seed) {}

  int Uniform(int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng_); }

  // One random edit; `tokens` are replacement words for header/field edits.
  std::string Mutate(std::string text, const std::vector<std::string>& tokens) {
    const int edits = Uniform(1, 3);
    for (int e = 0; e < edits; ++e) {
      const int size = static_cast<int>(text.size());
      const int pos = size == 0 ? 0 : Uniform(0, size - 1);
      switch (Uniform(0, 7)) {
        case 0:  // flip one bit
          if (size > 0) text[pos] = static_cast<char>(text[pos] ^ (1 << Uniform(0, 7)));
          break;
        case 1:  // random byte
          if (size > 0) text[pos] = static_cast<char>(Uniform(0, 255));
          break;
        case 2:  // truncate
          text.resize(pos);
          break;
        case 3:  // insert random bytes
          text.insert(pos, std::string(Uniform(1, 8), static_cast<char>(Uniform(0, 255))));
          break;
        case 4:  // delete a run
          text.erase(pos, Uniform(1, 16));
          break;
        case 5:  // duplicate a run
          text.insert(pos, text.substr(pos, Uniform(1, 64)));
          break;
        case 6:    // replace a word (header field, YAML key or number) by a nasty token
        case 7: {  // ... preferably near the beginning, where headers live
          const int at = Uniform(0, 1) ? pos : std::min(pos, Uniform(0, 40));
          const size_t begin = text.find_first_not_of(" \n\r\t:[],", at);
          if (begin == std::string::npos) break;
          const size_t end = text.find_first_of(" \n\r\t:[],", begin);
          text.replace(begin, (end == std::string::npos ? text.size() : end) - begin,
                       tokens[Uniform(0, static_cast<int>(tokens.size()) - 1)]);
          break;
        }
      }
    }
    return text;
  }

 private:
  std::mt19937_64 rng_;
};

cv::Mat SmallImage(int rows, int cols, int channels, std::uint64_t seed) {
  cv::Mat image(rows, cols, CV_MAKETYPE(CV_32F, channels));
  cv::RNG(seed).fill(image, cv::RNG::UNIFORM, -50.0, 50.0);
  image.at<float>(0, 0) = std::numeric_limits<float>::infinity();
  return image;
}

TEST(ParserRobustnessTest, MutatedPfmDecodesOrThrowsInputError) {
  std::vector<std::string> seeds = {EncodePfm(SmallImage(3, 5, 1, 1)),
                                    EncodePfm(SmallImage(2, 2, 3, 2)),
                                    EncodePfm(SmallImage(1, 7, 1, 3))};
  // A big-endian file with a Middlebury-style scale and extra header whitespace.
  std::string big_endian = "Pf \n2 3 \n0.003922\n";
  for (int i = 0; i < 6; ++i) big_endian += std::string("\x41\x20\x00\x00", 4);
  seeds.push_back(big_endian);
  const std::vector<std::string> tokens = {
      "0",     "-1",  "1",    "-0",   "4294967297", "99999999999999999999",
      "abc",   "nan", "-inf", "",     "1e400",      "268435457",
      "16384", "2 3", "+5",   "0x10", "Pf",         "PF"};
  Mutator mutator(20261122);
  int decoded = 0, rejected = 0;
  for (int i = 0; i < 4000; ++i) {
    const std::string& seed = seeds[i % seeds.size()];
    const std::string input = mutator.Mutate(seed, tokens);
    try {
      const cv::Mat image = DecodePfm(input, "fuzz.pfm");
      ASSERT_FALSE(image.empty());
      ASSERT_TRUE(image.type() == CV_32FC1 || image.type() == CV_32FC3);
      ASSERT_LE(image.total() * image.elemSize(), input.size());
      ++decoded;
    } catch (const InputError& e) {
      ASSERT_NE(std::string(e.what()).find("fuzz.pfm"), std::string::npos) << e.what();
      ++rejected;
    }
  }
  // Both outcomes must be exercised, or the mutations are not testing anything.
  EXPECT_GT(decoded, 200);
  EXPECT_GT(rejected, 1000);
}

std::string ValidCalibrationYaml() {
  StereoCalibration c;
  c.image_size = cv::Size(320, 240);
  c.M1 = (cv::Mat_<double>(3, 3) << 350, 0, 160, 0, 350, 120, 0, 0, 1);
  c.M2 = c.M1.clone();
  c.D1 = cv::Mat::zeros(1, 5, CV_64F);
  c.D2 = cv::Mat::zeros(1, 5, CV_64F);
  c.R = cv::Mat::eye(3, 3, CV_64F);
  c.T = (cv::Mat_<double>(3, 1) << -0.1, 0, 0);
  c.E = (cv::Mat_<double>(3, 3) << 0, 0, 0, 0, 0, 0.1, 0, -0.1, 0);
  c.F = c.E.clone();
  cv::stereoRectify(c.M1, c.D1, c.M2, c.D2, c.image_size, c.R, c.T, c.R1, c.R2, c.P1, c.P2, c.Q);
  return EncodeStereoCalibration(c);
}

TEST(ParserRobustnessTest, MutatedCalibrationYamlDecodesOrThrowsInputError) {
  const std::string seed = ValidCalibrationYaml();
  ASSERT_NO_THROW(DecodeStereoCalibration(seed, "seed.yml"));
  const std::vector<std::string> tokens = {
      "0",     "-1",          "3",         "4",    "99999999999",
      "1e400", "nan",         ".inf",      "abc",  "\"x\"",
      "[",     "]",           "{",         "}",    "!!opencv-matrix",
      "rows",  "cols",        "dt",        "data", "M1",
      "Q",     "image_width", "%YAML:1.0", "&a",   "*a",
      "<<",    "- 1",         "'",         "\"",   "#",
      "|",     ">",           "!!str",     "...",  "---",
      "\t",    "u",           "2d",        "i",    "f",
      "3x"};
  Mutator mutator(7);
  int decoded = 0, rejected = 0;
  for (int i = 0; i < 2500; ++i) {
    const std::string input = mutator.Mutate(seed, tokens);
    try {
      const StereoCalibration c = DecodeStereoCalibration(input, "fuzz.yml");
      ASSERT_EQ(c.M1.size(), cv::Size(3, 3));
      ASSERT_EQ(c.T.size(), cv::Size(1, 3));
      ASSERT_EQ(c.Q.size(), cv::Size(4, 4));
      ASSERT_EQ(c.P2.size(), cv::Size(4, 3));
      ++decoded;
    } catch (const InputError& e) {
      ASSERT_NE(std::string(e.what()).find("fuzz.yml"), std::string::npos) << e.what();
      ++rejected;
    } catch (const std::exception& e) {
      FAIL() << "input " << i << " threw " << typeid(e).name() << ": " << e.what() << "\n---\n"
             << input;
    }
  }
  EXPECT_GT(decoded, 50);
  EXPECT_GT(rejected, 1000);
}

}  // namespace
}  // namespace linesight
