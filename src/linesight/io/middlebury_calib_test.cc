#include "linesight/io/middlebury_calib.h"

#include <gtest/gtest.h>

#include "linesight/core/atomic_file.h"
#include "linesight/io/io_test_util.h"

namespace linesight {
namespace {
using testing::ExpectInputError;

// Motorcycle of Middlebury 2014 at quarter size.
const char* kMotorcycle =
    "cam0=[999.421 0 294.182; 0 999.421 252.932; 0 0 1]\n"
    "cam1=[999.421 0 326.96; 0 999.421 252.932; 0 0 1]\n"
    "doffs=32.778\n"
    "baseline=193.001\n"
    "width=741\n"
    "height=497\n"
    "ndisp=70\n"
    "isint=0\n"
    "vmin=7\n"
    "vmax=65\n";

// Every parsed field equals its expected value (exactly: the text holds them as written).
void ExpectCalib(const MiddleburyCalib& c, const MiddleburyCalib& expected) {
  EXPECT_EQ(c.focal_px, expected.focal_px);
  EXPECT_EQ(c.cx, expected.cx);
  EXPECT_EQ(c.cy, expected.cy);
  EXPECT_EQ(c.doffs_px, expected.doffs_px);
  EXPECT_EQ(c.baseline_mm, expected.baseline_mm);
  EXPECT_EQ(c.num_disparities, expected.num_disparities);
}

TEST(MiddleburyCalib, ParsesTheCameraMatrixOffsetBaselineAndDisparities) {
  ExpectCalib(ParseMiddleburyCalib(kMotorcycle, "calib.txt"),
              {999.421, 294.182, 252.932, 32.778, 193.001, 70});
}

TEST(MiddleburyCalib, NdispIsOptionalAndSpacesAroundKeysAreIgnored) {
  ExpectCalib(
      ParseMiddleburyCalib(
          "cam0 = [700 0 300.5; 0 700 200.25; 0 0 1]\r\n doffs=0\nbaseline = 120\n", "eth3d"),
      {700, 300.5, 200.25, 0, 120, 0});
}

TEST(MiddleburyCalib, ErrorsNameTheSourceAndTheField) {
  const std::string cam0 = "cam0=[999 0 294; 0 999 252; 0 0 1]\n";
  ExpectInputError([&] { ParseMiddleburyCalib(cam0 + "doffs=32.7\n", "m/calib.txt"); },
                   {"m/calib.txt", "'baseline' is missing"});
  ExpectInputError([&] { ParseMiddleburyCalib(cam0 + "doffs=x\nbaseline=193\n", "m/calib.txt"); },
                   {"m/calib.txt", "'doffs=x' is not a number"});
  ExpectInputError([&] { ParseMiddleburyCalib(cam0 + "doffs=1\nbaseline=-3\n", "c"); },
                   {"'baseline' must be positive"});
  ExpectInputError([&] { ParseMiddleburyCalib(cam0 + "doffs=1\nbaseline=3\nndisp=7.5\n", "c"); },
                   {"'ndisp' must be a positive integer, got 7.5"});
  ExpectInputError([] { ParseMiddleburyCalib("cam0=[999 0 294]\ndoffs=1\nbaseline=3\n", "c"); },
                   {"'cam0' must be a 3x3 matrix"});
  ExpectInputError(
      [] { ParseMiddleburyCalib("cam0=[0 0 1; 0 0 1; 0 0 1]\ndoffs=1\nbaseline=3\n", "c"); },
      {"with f > 0"});
  ExpectInputError([] { ParseMiddleburyCalib("doffs=1\nbaseline=3\n", "c"); },
                   {"'cam0' is missing"});
}

class MiddleburyCalibFileTest : public testing::TempDirTest {};

TEST_F(MiddleburyCalibFileTest, ReadsAFileAndNamesItInErrors) {
  WriteTextAtomic(dir_ / "calib.txt", kMotorcycle);
  EXPECT_EQ(ReadMiddleburyCalib(dir_ / "calib.txt").num_disparities, 70);
  WriteTextAtomic(dir_ / "bad.txt", "doffs=1\n");
  ExpectInputError([&] { ReadMiddleburyCalib(dir_ / "bad.txt"); }, {(dir_ / "bad.txt").string()});
  ExpectInputError([&] { ReadMiddleburyCalib(dir_ / "missing.txt"); }, {"missing.txt"});
}

}  // namespace
}  // namespace linesight
