#include "linesight/server/base_station.h"

#include <httplib.h>

#include <random>
#include <string>
#include <thread>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "linesight/core/error.h"

namespace linesight {
namespace {

const cv::Size kImage(752, 480);

TEST(ParseRoiRequest, AcceptsRoisAndAuto) {
  const RoiRequest r =
      ParseRoiRequest(R"({"rois": [[1, 2, 30, 40], [0, 0, 752, 480]], "auto": false})", kImage);
  ASSERT_TRUE(r.rois);
  ASSERT_EQ(r.rois->size(), 2u);
  EXPECT_EQ((*r.rois)[0], cv::Rect(1, 2, 30, 40));
  EXPECT_EQ((*r.rois)[1], cv::Rect(0, 0, 752, 480));
  ASSERT_TRUE(r.auto_detect);
  EXPECT_FALSE(*r.auto_detect);
  const RoiRequest only_auto = ParseRoiRequest(R"({"auto": true})", kImage);
  EXPECT_FALSE(only_auto.rois);
  EXPECT_TRUE(*only_auto.auto_detect);
  EXPECT_TRUE(ParseRoiRequest(R"({"rois": []})", kImage).rois->empty());
}

void ExpectRejected(const std::string& body, const std::string& fragment) {
  try {
    ParseRoiRequest(body, kImage);
    ADD_FAILURE() << body << " accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos)
        << body << " -> " << e.what();
  }
}

TEST(ParseRoiRequest, NamesWhatIsWrong) {
  ExpectRejected("", "not valid JSON");
  ExpectRejected("{\"rois\": [", "not valid JSON");
  ExpectRejected("[1,2,3,4]", "expected a JSON object");
  ExpectRejected(R"({"roi": []})", "unknown field 'roi'");
  ExpectRejected(R"({"auto": 1})", "'auto' must be true or false");
  ExpectRejected(R"({"rois": {}})", "'rois' must be an array");
  ExpectRejected(R"({"rois": [[1, 2, 3]]})", "rois[0]: expected [x, y, w, h]");
  ExpectRejected(R"({"rois": [[0,0,5,5], [1.5, 2, 3, 4]]})", "rois[1]: expected");
  ExpectRejected(R"({"rois": [["1", 2, 3, 4]]})", "rois[0]: expected");
  ExpectRejected(R"({"rois": [[700, 10, 100, 50]]})", "rois[0] = 700,10,100,50 is not inside");
  ExpectRejected(R"({"rois": [[10, 10, 0, 5]]})", "is not inside");
  ExpectRejected(R"({"rois": [[-1, 10, 5, 5]]})", "is not inside");
  ExpectRejected(R"({"rois": [[2147483647, 10, 5, 5]]})", "rois[0]: expected");
  std::string many = R"({"rois": [)";
  for (int i = 0; i < 33; ++i) many += std::string(i ? "," : "") + "[0,0,1,1]";
  ExpectRejected(many + "]}", "at most 32 ROIs");
}

// Seeded mutation test of the API body parser (the libFuzzer target base_station_fuzz runs the same
// decoder): every mutant must parse or throw InputError, never crash or throw anything else.
TEST(ParseRoiRequest, MutantsParseOrThrowInputError) {
  const std::vector<std::string> seeds = {
      R"({"rois": [[1, 2, 30, 40], [100, 200, 50, 60]], "auto": true})", R"({"auto": false})",
      R"({"rois": []})"};
  const std::string alphabet = "{}[],:\"0123456789-+.eE truefalsnl\\u\x01\xff";
  std::mt19937 rng(11);
  int parsed = 0, rejected = 0;
  for (int i = 0; i < 5000; ++i) {
    std::string body = seeds[i % seeds.size()];
    const int edits = 1 + static_cast<int>(rng() % 4);
    for (int e = 0; e < edits && !body.empty(); ++e) {
      const size_t pos = rng() % body.size();
      switch (rng() % 3) {
        case 0:
          body[pos] = alphabet[rng() % alphabet.size()];
          break;
        case 1:
          body.erase(pos, 1 + rng() % 3);
          break;
        default:
          body.insert(pos, 1, alphabet[rng() % alphabet.size()]);
      }
    }
    try {
      ParseRoiRequest(body, kImage);
      ++parsed;
    } catch (const InputError&) {
      ++rejected;
    }
  }
  EXPECT_GT(parsed, 50);
  EXPECT_GT(rejected, 1000);
}

TEST(BaseStationOptions, DefaultsAreValid) {
  EXPECT_NO_THROW(BaseStationOptions().Check());
  BaseStationOptions o;
  o.jpeg_quality = 0;
  EXPECT_THROW(o.Check(), OptionError);
}

TEST(BaseStation, NeedsACalibration) {
  const std::string dir = ::testing::TempDir();
  const std::string l = dir + "/bs_l.png", r = dir + "/bs_r.png";
  cv::imwrite(l, cv::Mat(40, 60, CV_8UC3, cv::Scalar::all(90)));
  cv::imwrite(r, cv::Mat(40, 60, CV_8UC3, cv::Scalar::all(90)));
  try {
    BaseStation station(OpenFrameSource("pair:" + l + "," + r), std::nullopt, {});
    FAIL() << "a source without calibration was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("give --calib"), std::string::npos) << e.what();
  }
}

// The whole base station on the synthetic scene: the loop ranges a damper at 2 m, the HTTP API
// serves status, result, images and ROI changes, and errors come back as JSON with 4xx.
TEST(BaseStation, ServesTheSyntheticSceneOverHttp) {
  FrameSourceOptions source_options;
  source_options.synthetic_supersampling = 1;
  source_options.synthetic_obstacles = "damper:2";
  BaseStationOptions options;
  options.pipeline.min_depth_m = 1.0;  // fewer disparities: a faster test
  options.pipeline.max_depth_m = 6.0;
  options.max_frames = 3;
  BaseStation station(OpenFrameSource("synthetic:1", source_options), std::nullopt, options);
  BaseStationServer server(&station);
  const int port = server.Bind("127.0.0.1", 0);
  ASSERT_GT(port, 0);
  std::thread http([&] { server.Listen(); });
  httplib::Client client("127.0.0.1", port);
  client.set_read_timeout(60, 0);

  // Before the first frame: 503 with a JSON error.
  auto early = client.Get("/api/frame/left.jpg");
  ASSERT_TRUE(early);
  EXPECT_EQ(early->status, 503);

  station.Start();
  while (station.running()) station.WaitForFrame(station.Snapshot().frame_index, 1.0);
  EXPECT_EQ(station.error(), "");

  auto status = client.Get("/api/status");
  ASSERT_TRUE(status);
  ASSERT_EQ(status->status, 200);
  const auto s = nlohmann::json::parse(status->body);
  EXPECT_EQ(s["frame"], 2);
  EXPECT_EQ(s["image_size"][0], 752);
  EXPECT_EQ(s["running"], false);

  auto result = client.Get("/api/result?after=-1");
  ASSERT_TRUE(result);
  ASSERT_EQ(result->status, 200);
  const auto j = nlohmann::json::parse(result->body);
  ASSERT_FALSE(j["tracks"].empty()) << result->body;
  // The nearest track is the damper, filtered over three frames.
  const double d = j["tracks"][0]["distance_m"];
  EXPECT_NEAR(d, 2.0, 0.06) << result->body;
  EXPECT_GT(j["tracks"][0]["sigma_m"].get<double>(), 0);
  EXPECT_EQ(j["tracks"][0]["updates"], 3);
  // Every per-frame measurement says whether it fed a track; the damper's did.
  ASSERT_FALSE(j["measurements"].empty());
  int tracked = 0;
  for (const auto& m : j["measurements"]) {
    ASSERT_TRUE(m.contains("tracked") && m["tracked"].is_boolean()) << m.dump();
    tracked += m["tracked"].get<bool>();
  }
  EXPECT_GE(tracked, 1);

  auto left = client.Get("/api/frame/left.jpg");
  ASSERT_TRUE(left);
  ASSERT_EQ(left->status, 200);
  EXPECT_EQ(left->get_header_value("Content-Type"), "image/jpeg");
  const cv::Mat decoded =
      cv::imdecode(std::vector<uint8_t>(left->body.begin(), left->body.end()), cv::IMREAD_COLOR);
  EXPECT_EQ(decoded.size(), kImage);
  auto disparity = client.Get("/api/frame/disparity.jpg");
  ASSERT_TRUE(disparity);
  EXPECT_EQ(disparity->status, 200);

  auto page = client.Get("/");
  ASSERT_TRUE(page);
  EXPECT_EQ(page->status, 200);
  EXPECT_NE(page->body.find("linesight base station"), std::string::npos);
  EXPECT_NE(page->body.find("/api/result"), std::string::npos);

  auto set = client.Post("/api/rois", R"({"rois": [[300, 150, 60, 60]], "auto": false})",
                         "application/json");
  ASSERT_TRUE(set);
  EXPECT_EQ(set->status, 200);
  EXPECT_EQ(nlohmann::json::parse(set->body)["rois"][0][0], 300);
  EXPECT_EQ(nlohmann::json::parse(set->body)["auto"], false);

  auto bad = client.Post("/api/rois", R"({"rois": [[700, 10, 100, 50]]})", "application/json");
  ASSERT_TRUE(bad);
  EXPECT_EQ(bad->status, 400);
  EXPECT_NE(nlohmann::json::parse(bad->body)["error"].get<std::string>().find("not inside"),
            std::string::npos);
  auto bad_after = client.Get("/api/result?after=x");
  ASSERT_TRUE(bad_after);
  EXPECT_EQ(bad_after->status, 400);
  auto missing = client.Get("/api/nothing");
  ASSERT_TRUE(missing);
  EXPECT_EQ(missing->status, 404);
  EXPECT_NE(missing->body.find("no such resource"), std::string::npos);

  server.Stop();
  http.join();
}

}  // namespace
}  // namespace linesight
