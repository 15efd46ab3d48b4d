// Conductor defects of the power-line scene: specs, random layouts, rendering and ground truth.
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "linesight/core/error.h"
#include "linesight/io/image_io.h"
#include "linesight/io/json_io.h"
#include "linesight/sim/power_line_scene.h"

namespace linesight::sim {
namespace {

// The full-size rig (thin strands need its resolution) with one ray per pixel, no towers and no
// obstacles: fast, and nothing but the line and its defects in front of the sky and the ground.
PowerLineSceneOptions DefectScene(std::vector<DefectSpec> defects) {
  PowerLineSceneOptions o;
  o.sensor.supersampling = 1;
  o.sensor.noise_sigma_dn = 0;
  o.towers = false;
  o.num_conductors = 1;
  o.obstacles.clear();
  o.defects = std::move(defects);
  return o;
}

DefectSpec Defect(DefectType type, double arc_m) {
  DefectSpec spec;
  spec.type = type;
  spec.arc_m = arc_m;
  return spec;
}

// Rectified left pixel of the point of conductor 0's axis at `arc_m`.
cv::Point2d AxisPixel(const PowerLineScene& scene, double arc_m) {
  const auto nearest =
      std::min_element(scene.conductor_axis.begin(), scene.conductor_axis.end(),
                       [&](const ConductorAxisPoint& a, const ConductorAxisPoint& b) {
                         return std::fabs(a.arc_m - arc_m) < std::fabs(b.arc_m - arc_m);
                       });
  const cv::Mat& p1 = scene.calibration.P1;
  const cv::Point3d x = nearest->rect;
  return {p1.at<double>(0, 0) * x.x / x.z + p1.at<double>(0, 2),
          p1.at<double>(1, 1) * x.y / x.z + p1.at<double>(1, 2)};
}

void ExpectThrowsMentioning(const std::string& text, const std::string& needle) {
  try {
    ParseDefectSpecs(text);
    ADD_FAILURE() << "accepted '" << text << "'";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
  }
}

TEST(ParseDefectSpecs, ParsesEveryTypeAndKey) {
  const std::vector<DefectSpec> specs = ParseDefectSpecs(
      "birdcage:2.0:swelling=0.3:length=0.15,string:3.1:length=0.4:angle=-20,"
      "broken_strands:2.5:strands=2:standoff=0.02:angle=90,sheet:4:side=0.25,nest:5.5:diameter=0.3,"
      "nest:-1");
  ASSERT_EQ(specs.size(), 6u);
  EXPECT_EQ(specs[0].type, DefectType::kBirdcage);
  EXPECT_DOUBLE_EQ(specs[0].arc_m, 2.0);
  EXPECT_DOUBLE_EQ(specs[0].swelling, 0.3);
  EXPECT_DOUBLE_EQ(specs[0].length_m, 0.15);
  EXPECT_EQ(specs[1].type, DefectType::kHangingString);
  EXPECT_DOUBLE_EQ(specs[1].length_m, 0.4);
  EXPECT_DOUBLE_EQ(specs[1].angle_deg, -20.0);
  EXPECT_EQ(specs[2].type, DefectType::kBrokenStrands);
  EXPECT_EQ(specs[2].strands, 2);
  EXPECT_DOUBLE_EQ(specs[2].standoff_m, 0.02);
  EXPECT_DOUBLE_EQ(specs[2].angle_deg, 90.0);
  EXPECT_EQ(specs[3].type, DefectType::kPlasticSheet);
  EXPECT_DOUBLE_EQ(specs[3].length_m, 0.25);
  EXPECT_EQ(specs[4].type, DefectType::kBirdNest);
  EXPECT_DOUBLE_EQ(specs[4].length_m, 0.3);
  EXPECT_DOUBLE_EQ(specs[5].arc_m, -1.0);
  EXPECT_DOUBLE_EQ(specs[5].length_m, DefectSpec().length_m);  // defaults where not given
  EXPECT_TRUE(ParseDefectSpecs("").empty());
  for (DefectType type : AllDefectTypes()) {
    EXPECT_EQ(ParseDefectType(DefectTypeName(type)), type);
  }
  EXPECT_EQ(AllDefectTypes().size(), 5u);
  EXPECT_EQ(DefectTypeName(DefectType::kBrokenStrands), "broken_strands");
  EXPECT_EQ(DefectTypeName(DefectType::kHangingString), "string");
  EXPECT_EQ(DefectTypeName(DefectType::kPlasticSheet), "sheet");
  EXPECT_EQ(DefectTypeName(DefectType::kBirdNest), "nest");
}

TEST(ParseDefectSpecs, ErrorsNameTheEntryKeyAndValue) {
  ExpectThrowsMentioning("crack:2", "'crack:2'");
  ExpectThrowsMentioning("crack:2", "birdcage, broken_strands, string, sheet or nest");
  ExpectThrowsMentioning("birdcage", "expected type:arc_m");
  ExpectThrowsMentioning("birdcage:far", "arc 'far' is not a number");
  ExpectThrowsMentioning("birdcage:2:swelling", "'swelling' is not a key=value");
  ExpectThrowsMentioning("birdcage:2:swelling=lots", "swelling 'lots' is not a number");
  ExpectThrowsMentioning("birdcage:2:swelling=1.5", "swelling = 1.5");
  ExpectThrowsMentioning("birdcage:2:length=0.9", "length_m = 0.9");
  ExpectThrowsMentioning("nest:2:swelling=0.3", "keys: length, diameter");
  ExpectThrowsMentioning("string:2:colour=red", "'colour=red'");
  ExpectThrowsMentioning("broken_strands:2:strands=4", "strands = 4");
  ExpectThrowsMentioning("broken_strands:2:strands=1.5", "strands = 1.5");
  ExpectThrowsMentioning("broken_strands:2:standoff=0.2", "standoff_m = 0.2");
  ExpectThrowsMentioning("sheet:2:length=0.8", "sheet");
  ExpectThrowsMentioning("string:2:angle=400", "angle_deg = 400");
  ExpectThrowsMentioning("birdcage:2,", "defect ''");
  ExpectThrowsMentioning("birdcage:2,nest:x", "'nest:x'");
}

TEST(PowerLineSceneOptions, ChecksEveryDefectField) {
  auto expect_rejected = [](auto mutate, const char* field) {
    PowerLineSceneOptions o;
    o.defects = {DefectSpec{}, DefectSpec{}};
    mutate(o.defects[1]);
    try {
      o.Check();
      ADD_FAILURE() << "accepted a bad " << field;
    } catch (const OptionError& e) {
      EXPECT_NE(
          std::string(e.what()).find(std::string("PowerLineSceneOptions.defects[1].") + field),
          std::string::npos)
          << e.what();
    }
  };
  expect_rejected([](DefectSpec& d) { d.arc_m = 75; }, "arc_m");
  expect_rejected([](DefectSpec& d) { d.arc_m = -60; }, "arc_m");
  expect_rejected([](DefectSpec& d) { d.arc_m = std::nan(""); }, "arc_m");
  expect_rejected([](DefectSpec& d) { d.swelling = 0.01; }, "swelling");
  expect_rejected([](DefectSpec& d) { d.length_m = 0.6; }, "length_m");  // birdcage: <= 0.5
  expect_rejected(
      [](DefectSpec& d) {
        d.type = DefectType::kBirdNest;
        d.length_m = 0.04;
      },
      "length_m");
  expect_rejected([](DefectSpec& d) { d.strands = 0; }, "strands");
  expect_rejected([](DefectSpec& d) { d.standoff_m = 0.1; }, "standoff_m");
  expect_rejected([](DefectSpec& d) { d.angle_deg = -400; }, "angle_deg");
  PowerLineSceneOptions o;
  EXPECT_TRUE(o.defects.empty());
  o.defects = {Defect(DefectType::kHangingString, 2.0)};
  o.defects[0].length_m = 1.5;
  EXPECT_NO_THROW(o.Check());
}

TEST(RandomDefects, DeterministicSpacedAndWithinTheirRanges) {
  const std::vector<DefectSpec> a = RandomDefects(11, 40, 1.0, 40.0);
  const std::vector<DefectSpec> b = RandomDefects(11, 40, 1.0, 40.0);
  ASSERT_EQ(a.size(), 40u);
  std::vector<int> seen(5, 0);
  for (size_t i = 0; i < a.size(); ++i) {
    const DefectSpec& d = a[i];
    EXPECT_EQ(d.type, b[i].type);
    EXPECT_EQ(d.arc_m, b[i].arc_m);
    EXPECT_EQ(d.length_m, b[i].length_m);
    EXPECT_EQ(d.swelling, b[i].swelling);
    EXPECT_EQ(d.standoff_m, b[i].standoff_m);
    EXPECT_EQ(d.angle_deg, b[i].angle_deg);
    EXPECT_GE(d.arc_m, 1.0);
    EXPECT_LE(d.arc_m, 40.0);
    if (i > 0) {
      EXPECT_GE(d.arc_m - a[i - 1].arc_m, 0.5 - 1e-12);
    }
    ++seen[static_cast<int>(d.type)];
    switch (d.type) {
      case DefectType::kBirdcage:
        EXPECT_GE(d.swelling, 0.1);
        EXPECT_LE(d.swelling, 0.5);
        EXPECT_GE(d.length_m, 0.05);
        EXPECT_LE(d.length_m, 0.3);
        break;
      case DefectType::kBrokenStrands:
        EXPECT_GE(d.strands, 1);
        EXPECT_LE(d.strands, 3);
        EXPECT_GE(d.standoff_m, 0.003);
        EXPECT_LE(d.standoff_m, 0.05);
        EXPECT_GE(d.angle_deg, 0.0);
        EXPECT_LE(d.angle_deg, 360.0);
        break;
      case DefectType::kHangingString:
        EXPECT_GE(d.length_m, 0.05);
        EXPECT_LE(d.length_m, 0.6);
        EXPECT_LE(std::fabs(d.angle_deg), 30.0);
        break;
      case DefectType::kPlasticSheet:
        EXPECT_GE(d.length_m, 0.05);
        EXPECT_LE(d.length_m, 0.4);
        EXPECT_LE(std::fabs(d.angle_deg), 30.0);
        break;
      case DefectType::kBirdNest:
        EXPECT_GE(d.length_m, 0.15);
        EXPECT_LE(d.length_m, 0.4);
        break;
    }
    // Every random defect is a valid spec.
    PowerLineSceneOptions o;
    o.defects = {d};
    EXPECT_NO_THROW(o.Check());
  }
  for (int count : seen) EXPECT_GT(count, 0);  // all five types among 40
  const std::vector<DefectSpec> other = RandomDefects(12, 40, 1.0, 40.0);
  bool differs = false;
  for (size_t i = 0; i < a.size(); ++i) differs |= other[i].arc_m != a[i].arc_m;
  EXPECT_TRUE(differs);
  EXPECT_TRUE(RandomDefects(11, 0, 1.0, 2.0).empty());
  // Exactly fits: 3 defects 0.5 m apart in 1 m.
  const std::vector<DefectSpec> tight = RandomDefects(3, 3, 2.0, 3.0);
  ASSERT_EQ(tight.size(), 3u);
  EXPECT_NEAR(tight[0].arc_m, 2.0, 1e-12);
  EXPECT_NEAR(tight[2].arc_m, 3.0, 1e-12);
  EXPECT_THROW(RandomDefects(3, 4, 2.0, 3.0), InputError);
}

// Each type, at 1.5 m of arc, shows on the conductor's image; its mask and truth agree.
TEST(RenderPowerLineScene, EveryDefectTypeIsSeenOnTheConductorWithExactTruth) {
  for (DefectType type : AllDefectTypes()) {
    SCOPED_TRACE(DefectTypeName(type));
    const PowerLineScene scene = RenderPowerLineScene(DefectScene({Defect(type, 1.5)}));
    ASSERT_EQ(scene.defects.size(), 1u);
    const RenderedDefect& d = scene.defects[0];
    EXPECT_EQ(d.id, 1);
    EXPECT_EQ(d.type, type);
    EXPECT_DOUBLE_EQ(d.arc_m, 1.5);
    EXPECT_LT(d.arc_begin_m, 1.5);
    EXPECT_GT(d.arc_end_m, 1.5);
    EXPECT_LT(d.arc_end_m - d.arc_begin_m, 0.5);
    // A single 3.5 mm wire is under 2 px wide here.
    EXPECT_GT(d.visible_pixels, type == DefectType::kBrokenStrands ? 5 : 20);
    EXPECT_TRUE(std::isfinite(d.distance_m));
    EXPECT_GT(d.distance_m, 1.0);
    EXPECT_LT(d.distance_m, 1.6);
    // The box lies on the conductor: it holds the axis point at the defect's arc (give or take
    // the conductor's radius, 7 px here) and plain conductor pixels.
    const cv::Point2d axis = AxisPixel(scene, d.arc_m);
    const cv::Rect grown(d.box.x - 8, d.box.y - 8, d.box.width + 16, d.box.height + 16);
    EXPECT_TRUE(grown.contains(cv::Point(static_cast<int>(axis.x), static_cast<int>(axis.y))))
        << d.box << " " << axis;
    int plain_conductor = 0;
    const cv::Rect inside = grown & cv::Rect(0, 0, scene.depth.cols, scene.depth.rows);
    for (int v = inside.y; v < inside.br().y; ++v) {
      for (int u = inside.x; u < inside.br().x; ++u) {
        plain_conductor +=
            scene.defect_mask.at<uchar>(v, u) == 0 &&
            scene.surface_class.at<uchar>(v, u) == static_cast<uchar>(SurfaceClass::kConductor);
      }
    }
    EXPECT_GT(plain_conductor, 10);
    // defect_mask holds the id over exactly the counted pixels, inside the box, nearest at
    // distance_m; damage to the conductor is conductor, foreign objects are obstacle class, and
    // no defect pixel is an obstacle's.
    const SurfaceClass expected_class =
        type == DefectType::kBirdcage || type == DefectType::kBrokenStrands
            ? SurfaceClass::kConductor
            : SurfaceClass::kObstacle;
    int pixels = 0;
    double min_depth = std::numeric_limits<double>::infinity();
    for (int v = 0; v < scene.depth.rows; ++v) {
      for (int u = 0; u < scene.depth.cols; ++u) {
        const int id = scene.defect_mask.at<uchar>(v, u);
        if (id == 0) continue;
        ASSERT_EQ(id, 1);
        ++pixels;
        EXPECT_TRUE(d.box.contains({u, v}));
        EXPECT_EQ(scene.surface_class.at<uchar>(v, u), static_cast<uchar>(expected_class));
        EXPECT_EQ(scene.obstacle_mask.at<uchar>(v, u), 0);
        min_depth = std::min(min_depth, static_cast<double>(scene.depth.at<float>(v, u)));
      }
    }
    EXPECT_EQ(pixels, d.visible_pixels);
    EXPECT_DOUBLE_EQ(min_depth, d.distance_m);
  }
}

// Width (px) of the conductor's silhouette across its image at the axis point of `arc_m`: the run
// of conductor pixels through that point along the normal of the line's image.
double ConductorCrossWidth(const PowerLineScene& scene, double arc_m) {
  const cv::Point2d centre = AxisPixel(scene, arc_m);
  const cv::Point2d direction = AxisPixel(scene, arc_m + 0.05) - AxisPixel(scene, arc_m - 0.05);
  const cv::Point2d normal = cv::Point2d(-direction.y, direction.x) / cv::norm(direction);
  const auto conductor = [&](double t) {
    const cv::Point2d p = centre + t * normal;
    const int u = static_cast<int>(std::lround(p.x)), v = static_cast<int>(std::lround(p.y));
    return u >= 0 && v >= 0 && u < scene.surface_class.cols && v < scene.surface_class.rows &&
           scene.surface_class.at<uchar>(v, u) == static_cast<uchar>(SurfaceClass::kConductor);
  };
  if (!conductor(0.0)) return 0.0;
  constexpr double kStep = 0.25;
  double lo = 0.0, hi = 0.0;
  while (conductor(lo - kStep) && lo > -200) lo -= kStep;
  while (conductor(hi + kStep) && hi < 200) hi += kStep;
  return hi - lo + 1.0;
}

// A birdcage swells the conductor's ground-truth silhouette at the defect, about in proportion to
// its radius, and leaves it alone elsewhere; where it shows, its surface is nearer than the plain
// conductor's, and what sticks out beyond the plain silhouette is all defect.
TEST(RenderPowerLineScene, BirdcageWidensTheConductorsSilhouette) {
  DefectSpec birdcage = Defect(DefectType::kBirdcage, 1.5);
  birdcage.swelling = 0.5;
  birdcage.length_m = 0.25;
  const PowerLineScene plain = RenderPowerLineScene(DefectScene({}));
  const PowerLineScene swollen = RenderPowerLineScene(DefectScene({birdcage}));
  EXPECT_DOUBLE_EQ(swollen.defects[0].size_m, 0.5 * PowerLineSceneOptions().conductor_radius_m);
  // Profile of the width along the line: the widest cut near the defect against the plain line
  // there (the bulge seen nearly end-on is a disc of the swollen radius).
  double widest_ratio = 0.0;
  for (double arc = 1.3; arc <= 1.7 + 1e-9; arc += 0.01) {
    const double plain_width = ConductorCrossWidth(plain, arc);
    ASSERT_GT(plain_width, 8.0) << arc;
    widest_ratio = std::max(widest_ratio, ConductorCrossWidth(swollen, arc) / plain_width);
  }
  EXPECT_GT(widest_ratio, 1.35);
  EXPECT_LT(widest_ratio, 1.75);
  // Half a metre of arc away the line is untouched.
  for (double arc : {0.8, 2.2}) {
    EXPECT_EQ(ConductorCrossWidth(swollen, arc), ConductorCrossWidth(plain, arc)) << arc;
  }
  int nearer = 0, compared = 0, outside_plain = 0;
  for (int y = 0; y < plain.surface_class.rows; ++y) {
    for (int x = 0; x < plain.surface_class.cols; ++x) {
      const bool was =
          plain.surface_class.at<uchar>(y, x) == static_cast<uchar>(SurfaceClass::kConductor);
      const bool is =
          swollen.surface_class.at<uchar>(y, x) == static_cast<uchar>(SurfaceClass::kConductor);
      EXPECT_FALSE(was && !is) << x << "," << y;
      const bool defect = swollen.defect_mask.at<uchar>(y, x) == 1;
      if (is && !was) {
        ++outside_plain;
        EXPECT_TRUE(defect) << x << "," << y;
      }
      if (defect && was) {
        ++compared;
        EXPECT_LE(swollen.depth.at<float>(y, x), plain.depth.at<float>(y, x)) << x << "," << y;
        nearer += swollen.depth.at<float>(y, x) < plain.depth.at<float>(y, x) - 1e-3f;
      }
      if (!defect) {
        EXPECT_EQ(swollen.depth.at<float>(y, x), plain.depth.at<float>(y, x)) << x << "," << y;
      }
    }
  }
  EXPECT_GT(outside_plain, 50);
  EXPECT_GT(compared, 20);
  EXPECT_GT(nearer, compared / 2);
}

TEST(RenderPowerLineScene, ManyDefectsKeepTheirIdsAndObstaclesStayObstacles) {
  PowerLineSceneOptions o = DefectScene(
      ParseDefectSpecs("nest:1.2,string:1.8:length=0.3,birdcage:2.4,sheet:3:length=0.2"));
  o.obstacles = {{ObstacleType::kSuspensionClamp, 4.0, 0}};
  o.obstacles[0].arc_m = 4.0;
  const PowerLineScene scene = RenderPowerLineScene(o);
  ASSERT_EQ(scene.defects.size(), 4u);
  std::vector<int> counts(5, 0);
  for (int v = 0; v < scene.defect_mask.rows; ++v) {
    for (int u = 0; u < scene.defect_mask.cols; ++u) {
      const int id = scene.defect_mask.at<uchar>(v, u);
      ASSERT_LE(id, 4);
      ++counts[id];
      if (id != 0) {
        EXPECT_EQ(scene.obstacle_mask.at<uchar>(v, u), 0);
      }
    }
  }
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(scene.defects[i].id, i + 1);
    EXPECT_EQ(counts[i + 1], scene.defects[i].visible_pixels);
    EXPECT_GT(scene.defects[i].visible_pixels, 0);
    EXPECT_EQ(scene.defects[i].type, o.defects[i].type);
  }
  // The clamp keeps its id and its pixels.
  ASSERT_EQ(scene.obstacles.size(), 1u);
  EXPECT_GT(scene.obstacles[0].visible_pixels, 20);
  EXPECT_EQ(cv::countNonZero(scene.obstacle_mask == 1), scene.obstacles[0].visible_pixels);
  EXPECT_EQ(cv::countNonZero(scene.obstacle_mask > 1), 0);
}

// With no defects every output is what it was; defects out of sight (behind the camera) change no
// pixel and no truth of the rest of the scene.
TEST(RenderPowerLineScene, DefectsOutOfSightChangeNothingElse) {
  PowerLineSceneOptions o;
  o.sensor.supersampling = 2;
  o.rig.image_size = {376, 240};
  for (CameraIntrinsics* k : {&o.rig.left, &o.rig.right}) {
    k->fx *= 0.5;
    k->fy *= 0.5;
    k->cx = (k->cx + 0.5) * 0.5 - 0.5;
    k->cy = (k->cy + 0.5) * 0.5 - 0.5;
  }
  ASSERT_TRUE(o.defects.empty());
  const PowerLineScene none = RenderPowerLineScene(o);
  EXPECT_TRUE(none.defects.empty());
  ASSERT_EQ(none.defect_mask.size(), none.depth.size());
  EXPECT_EQ(none.defect_mask.type(), CV_8UC1);
  EXPECT_EQ(cv::countNonZero(none.defect_mask), 0);
  o.defects = ParseDefectSpecs("nest:-30,birdcage:-20,sheet:-25,string:-40,broken_strands:-45");
  const PowerLineScene hidden = RenderPowerLineScene(o);
  ASSERT_EQ(hidden.defects.size(), 5u);
  for (const RenderedDefect& d : hidden.defects) {
    EXPECT_EQ(d.visible_pixels, 0);
    EXPECT_TRUE(std::isinf(d.distance_m));
  }
  EXPECT_EQ(cv::countNonZero(hidden.defect_mask), 0);
  EXPECT_EQ(cv::norm(none.left, hidden.left, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(none.right, hidden.right, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(none.depth != hidden.depth, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(none.surface_class, hidden.surface_class, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(none.obstacle_mask, hidden.obstacle_mask, cv::NORM_INF), 0.0);
  ASSERT_EQ(none.obstacles.size(), hidden.obstacles.size());
  for (size_t i = 0; i < none.obstacles.size(); ++i) {
    EXPECT_EQ(none.obstacles[i].distance_m, hidden.obstacles[i].distance_m);
    EXPECT_EQ(none.obstacles[i].arc_m, hidden.obstacles[i].arc_m);
  }
  // The scene's files: defects.json and defect_mask.png only with defects.
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / fmt::format("linesight_defects_test_{}", ::getpid());
  std::filesystem::remove_all(dir);
  WritePowerLineScene(dir / "none", none);
  EXPECT_TRUE(std::filesystem::exists(dir / "none" / "obstacles.json"));
  EXPECT_FALSE(std::filesystem::exists(dir / "none" / "defects.json"));
  EXPECT_FALSE(std::filesystem::exists(dir / "none" / "defect_mask.png"));
  std::filesystem::remove_all(dir);
}

TEST(WritePowerLineScene, WritesTheDefectsAndTheirMask) {
  const PowerLineScene scene = RenderPowerLineScene(
      DefectScene(ParseDefectSpecs("nest:1.5:diameter=0.3,broken_strands:-10")));
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    fmt::format("linesight_defects_write_{}", ::getpid());
  std::filesystem::remove_all(dir);
  WritePowerLineScene(dir, scene);
  const cv::Mat mask = ReadImage(dir / "defect_mask.png", ImageColor::kGray);
  EXPECT_EQ(cv::norm(mask, scene.defect_mask, cv::NORM_INF), 0.0);
  const nlohmann::json json = ReadJson(dir / "defects.json");
  ASSERT_EQ(json["defects"].size(), 2u);
  const nlohmann::json& nest = json["defects"][0];
  EXPECT_EQ(nest["id"], 1);
  EXPECT_EQ(nest["type"], "nest");
  EXPECT_DOUBLE_EQ(nest["arc_m"].get<double>(), 1.5);
  EXPECT_DOUBLE_EQ(nest["size_m"].get<double>(), 0.3);
  EXPECT_DOUBLE_EQ(nest["distance_m"].get<double>(), scene.defects[0].distance_m);
  EXPECT_DOUBLE_EQ(nest["arc_begin_m"].get<double>(), scene.defects[0].arc_begin_m);
  EXPECT_DOUBLE_EQ(nest["arc_end_m"].get<double>(), scene.defects[0].arc_end_m);
  EXPECT_EQ(nest["box"][2], scene.defects[0].box.width);
  EXPECT_EQ(nest["visible_pixels"], scene.defects[0].visible_pixels);
  EXPECT_TRUE(json["defects"][1]["distance_m"].is_null());  // behind the camera
  EXPECT_EQ(json["defects"][1]["type"], "broken_strands");
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace linesight::sim
