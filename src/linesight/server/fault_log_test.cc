#include "linesight/server/fault_log.h"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "linesight/core/error.h"

namespace linesight {
namespace {

ConductorFault Birdcage(double arc_m, cv::Rect box = cv::Rect(100, 100, 20, 10)) {
  ConductorFault f;
  f.arc_m = arc_m;
  f.arc_begin_m = arc_m - 0.05;
  f.arc_end_m = arc_m + 0.05;
  f.distance_m = arc_m;
  f.size_m = 0.004;
  f.confidence = 0.6;
  f.box = box;
  return f;
}

TEST(FaultLogOptions, DefaultsAreValidAndEachBoundIsNamed) {
  EXPECT_NO_THROW(FaultLogOptions().Check());
  const auto rejected = [](FaultLogOptions o, const char* field) {
    try {
      o.Check();
      ADD_FAILURE() << field << " accepted";
    } catch (const OptionError& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  FaultLogOptions o;
  o.max_faults = 0;
  rejected(o, "max_faults");
  o = {};
  o.max_faults = 1001;
  rejected(o, "max_faults");
  o = {};
  o.gate_m = 0;
  rejected(o, "gate_m");
  o = {};
  o.gate_relative = -0.1;
  rejected(o, "gate_relative");
  o = {};
  o.crop_margin_px = -1;
  rejected(o, "crop_margin_px");
  o = {};
  o.crop_max_px = 15;
  rejected(o, "crop_max_px");
  o = {};
  o.jpeg_quality = 101;
  rejected(o, "jpeg_quality");
}

// A fault fixed on the line, seen from a robot riding towards it at 0.3 m/s at 2 fps: its arc
// shrinks by 0.15 m a frame (with +-2 cm of noise) and it stays one fault; a second fault 1 m
// farther on, in view from the third frame, stays another.
TEST(FaultLog, MergesAFixedFaultAsTheRobotAdvances) {
  FaultLog log;
  const double speed = 0.3, dt = 0.5;
  for (int frame = 0; frame < 6; ++frame) {
    const double t = frame * dt, advanced = speed * t;
    std::vector<ConductorFault> seen = {Birdcage(2.0 - advanced + (frame % 2 ? 0.02 : -0.02))};
    if (frame >= 2) seen.push_back(Birdcage(3.0 - advanced));
    const std::vector<int> ids = log.Update(frame, t, seen, {}, speed);
    ASSERT_EQ(ids.size(), seen.size());
    EXPECT_EQ(ids[0], 1) << "frame " << frame;
    if (frame >= 2) {
      EXPECT_EQ(ids[1], 2) << "frame " << frame;
    }
  }
  ASSERT_EQ(log.faults().size(), 2u);
  const LoggedFault* first = log.Find(1);
  ASSERT_NE(first, nullptr);
  EXPECT_EQ(first->sightings, 6);
  EXPECT_EQ(first->first_seen_frame, 0);
  EXPECT_EQ(first->last_seen_frame, 5);
  EXPECT_NEAR(first->last.arc_m, 2.0 - 0.3 * 2.5, 0.03);
  EXPECT_EQ(log.Find(2)->sightings, 4);
  EXPECT_EQ(log.Find(3), nullptr);
}

// Without a speed the last one given holds; a fault out of view is still listed, expected where
// the robot's motion puts it (behind the robot once passed).
TEST(FaultLog, PredictsTheArcOfAFaultOutOfViewWithTheLastSpeed) {
  FaultLog log;
  log.Update(0, 0.0, {Birdcage(0.5)}, {}, 0.4);
  log.Update(1, 1.0, {}, {}, std::nullopt);
  ASSERT_EQ(log.faults().size(), 1u);
  EXPECT_NEAR(log.faults()[0].arc_now_m, 0.1, 1e-9);
  log.Update(2, 2.0, {}, {}, std::nullopt);
  EXPECT_NEAR(log.faults()[0].arc_now_m, -0.3, 1e-9);
  EXPECT_EQ(log.faults()[0].last_seen_frame, 0);
  EXPECT_DOUBLE_EQ(log.robot_speed_mps(), 0.4);
  // Seen again where it is expected: the same fault.
  EXPECT_EQ(log.Update(3, 2.1, {Birdcage(-0.32)}, {}, std::nullopt), std::vector<int>{1});
}

TEST(FaultLog, KeepsApartFaultsOutsideTheGateAndOfOneFrame) {
  FaultLog log;
  // Two faults of one frame, 0.1 m apart, are two faults even though both are in each other's
  // gate: a kept fault takes at most one sighting per frame.
  EXPECT_EQ(log.Update(0, 0, {Birdcage(1.0), Birdcage(1.1)}, {}, 0.0), (std::vector<int>{1, 2}));
  EXPECT_EQ(log.Update(1, 0.1, {Birdcage(1.1), Birdcage(1.0)}, {}, 0.0), (std::vector<int>{2, 1}));
  // Beyond the gate (0.15 m + 10 % of 1.6 m = 0.31 m from 1.1 m): a new fault.
  EXPECT_EQ(log.Update(2, 0.2, {Birdcage(1.6)}, {}, 0.0), std::vector<int>{3});
}

// A foreign object that reads as a nest in one frame, as a sheet in the next and as a string (a
// sheet seen edge-on) in the third is one fault, listed with its latest type; a bird-cage at the
// same place is another.
TEST(FaultLog, AForeignObjectIsOneFaultWhicheverWayItReads) {
  FaultLog log;
  ConductorFault nest = Birdcage(1.0), sheet = Birdcage(1.02), string = Birdcage(0.98);
  nest.type = ConductorFaultType::kNest;
  sheet.type = ConductorFaultType::kSheet;
  string.type = ConductorFaultType::kString;
  EXPECT_EQ(log.Update(0, 0.0, {nest}, {}, 0.0), std::vector<int>{1});
  EXPECT_EQ(log.Update(1, 0.1, {sheet, Birdcage(1.0)}, {}, 0.0), (std::vector<int>{1, 2}));
  ASSERT_NE(log.Find(1), nullptr);
  EXPECT_EQ(log.Find(1)->sightings, 2);
  EXPECT_EQ(log.Find(1)->last.type, ConductorFaultType::kSheet);
  EXPECT_EQ(log.Update(2, 0.2, {string}, {}, 0.0), std::vector<int>{1});
  EXPECT_EQ(log.Find(1)->last.type, ConductorFaultType::kString);
}

TEST(FaultLog, KeepsAtMostMaxFaultsAndDropsTheOneSeenLongestAgo) {
  FaultLogOptions options;
  options.max_faults = 3;
  FaultLog log(options);
  const cv::Mat image(120, 160, CV_8UC3, cv::Scalar(40, 80, 120));
  for (int frame = 0; frame < 5; ++frame) {
    const JpegBytes crop = EncodeFaultCrop(image, cv::Rect(50, 50, 10, 6), options);
    log.Update(frame, frame, {Birdcage(1.0 + frame)}, {crop}, 0.0);
  }
  ASSERT_EQ(log.faults().size(), 3u);
  EXPECT_EQ(log.faults()[0].id, 5);  // the most recently seen first
  EXPECT_EQ(log.faults()[2].id, 3);
  EXPECT_EQ(log.Find(1), nullptr);
  EXPECT_EQ(log.Find(2), nullptr);
  ASSERT_TRUE(log.Find(4)->crop);
  const nlohmann::json j = log.Find(4)->ToJson("/api/fault/");
  EXPECT_EQ(j["crop"], "/api/fault/4.jpg");
  EXPECT_EQ(j["type"], "birdcage");
  EXPECT_NEAR(j["length_m"].get<double>(), 0.1, 1e-9);
  EXPECT_EQ(j["last_seen_frame"], 3);
  EXPECT_EQ(j["box"], nlohmann::json({100, 100, 20, 10}));
}

TEST(EncodeFaultCrop, CropsAroundTheBoxAndScalesLargeCropsDown) {
  FaultLogOptions options;
  cv::Mat image(480, 752, CV_8UC3, cv::Scalar(10, 20, 30));
  const auto decode = [](const JpegBytes& bytes) { return cv::imdecode(*bytes, cv::IMREAD_COLOR); };
  // A small box: grown by the margin on each side.
  JpegBytes small = EncodeFaultCrop(image, cv::Rect(100, 100, 20, 10), options);
  ASSERT_TRUE(small);
  EXPECT_EQ(decode(small).size(), cv::Size(20 + 2 * 12, 10 + 2 * 12));
  // Clipped at the image's border.
  EXPECT_EQ(decode(EncodeFaultCrop(image, cv::Rect(0, 0, 20, 10), options)).size(),
            cv::Size(20 + 12, 10 + 12));
  // A large box: grown by half its longer side, then scaled to crop_max_px.
  const cv::Mat large = decode(EncodeFaultCrop(image, cv::Rect(200, 100, 300, 100), options));
  EXPECT_EQ(large.cols, options.crop_max_px);
  // Grey images too; nothing for an empty box or one outside the image.
  const cv::Mat grey(100, 100, CV_8UC1, cv::Scalar(90));
  EXPECT_TRUE(EncodeFaultCrop(grey, cv::Rect(10, 10, 5, 5), options));
  EXPECT_FALSE(EncodeFaultCrop(image, cv::Rect(100, 100, 0, 10), options));
  EXPECT_FALSE(EncodeFaultCrop(image, cv::Rect(900, 100, 10, 10), options));
}

}  // namespace
}  // namespace linesight
