#include "linesight/server/base_station.h"

#include <httplib.h>

#include <random>
#include <string>
#include <thread>

#include <filesystem>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "linesight/core/error.h"
#include "linesight/sim/power_line_scene.h"
#include "linesight/sim/power_line_sequence.h"

namespace linesight {
namespace {

const cv::Size kImage(752, 480);

TEST(ParseAlarmRequest, AcceptsADistanceAndNamesWhatIsWrong) {
  EXPECT_DOUBLE_EQ(ParseAlarmRequest(R"({"distance_m": 1.5})"), 1.5);
  for (const char* body : {"", "[]", "{}", R"({"distance_m": "1"})", R"({"distance_m": 0})",
                           R"({"distance_m": 1e9})", R"({"distance_m": 1, "x": 2})"}) {
    EXPECT_THROW(ParseAlarmRequest(body), InputError) << body;
  }
  try {
    ParseAlarmRequest(R"({"distance_m": 0.01})");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("[0.05, 100]"), std::string::npos) << e.what();
  }
}

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

TEST(ParseFaultImageName, AcceptsAnIdAndNamesWhatIsExpected) {
  EXPECT_EQ(ParseFaultImageName("1.jpg"), 1);
  EXPECT_EQ(ParseFaultImageName("123456789.jpg"), 123456789);
  for (const char* name : {"", ".jpg", "0.jpg", "01.jpg", "-1.jpg", "+1.jpg", "1.png", "1.jpg.jpg",
                           "1", "x.jpg", "1 .jpg", "1234567890.jpg", "../status", "1.JPG"}) {
    try {
      ParseFaultImageName(name);
      ADD_FAILURE() << name << " accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("expected <id>.jpg"), std::string::npos) << e.what();
    }
  }
  // A long name is shown shortened.
  try {
    ParseFaultImageName(std::string(5000, '7'));
    FAIL();
  } catch (const InputError& e) {
    EXPECT_LT(std::string(e.what()).size(), 200u) << e.what();
  }
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
    try {
      const double d = ParseAlarmRequest(body);
      EXPECT_TRUE(d >= 0.05 && d <= 100) << body;
    } catch (const InputError&) {
    }
    try {
      EXPECT_GE(ParseFaultImageName(body), 1) << body;
    } catch (const InputError&) {
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

// A BaseStationServer on a free port of 127.0.0.1, listening on its own thread until destroyed,
// and a client for it.
struct LoopbackServer {
  explicit LoopbackServer(BaseStation* station)
      : server(station), port(server.Bind("127.0.0.1", 0)), client("127.0.0.1", port) {
    http = std::thread([this] { server.Listen(); });
    client.set_read_timeout(60, 0);
  }
  ~LoopbackServer() {
    server.Stop();
    http.join();
  }
  BaseStationServer server;
  int port;
  httplib::Client client;
  std::thread http;
};

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
  options.finder = AutoFinder::kRegions;
  BaseStation station(OpenFrameSource("synthetic:1", source_options), std::nullopt, options);
  LoopbackServer server(&station);
  httplib::Client& client = server.client;

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
  EXPECT_NE(page->body.find("/api/events"), std::string::npos);

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
}

// Push and record: every published frame reaches an event-stream client as a "frame" event with
// the status and the result, the annotated MJPEG stream delivers decodable JPEG parts, the status
// carries per-stage timing and the calibration's health, and the record switch writes a recording
// that the images: source reads back, pair for pair.
TEST(BaseStation, PushesEventsStreamsTheAnnotatedViewAndRecords) {
  namespace fs = std::filesystem;
  FrameSourceOptions source_options;
  source_options.synthetic_supersampling = 1;
  source_options.synthetic_obstacles = "damper:2";
  BaseStationOptions options;
  options.pipeline.min_depth_m = 1.0;
  options.pipeline.max_depth_m = 6.0;
  options.max_frames = 4;
  options.health_every_frames = 1;
  options.rois = {cv::Rect(300, 150, 60, 60)};
  options.record_dir = ::testing::TempDir() + "/bs_recordings";
  fs::remove_all(options.record_dir);
  BaseStation station(OpenFrameSource("synthetic:1", source_options), std::nullopt, options);
  LoopbackServer server(&station);

  auto bad = server.client.Post("/api/record", R"({"on": "yes"})", "application/json");
  ASSERT_TRUE(bad);
  EXPECT_EQ(bad->status, 400);
  auto record = server.client.Post("/api/record", R"({"on": true})", "application/json");
  ASSERT_TRUE(record);
  ASSERT_EQ(record->status, 200) << record->body;
  EXPECT_EQ(nlohmann::json::parse(record->body)["recording"]["on"], true);

  // Clients that read the streams until they have what they need (bounded by the frame count).
  std::string events, video;
  std::thread event_reader([&] {
    httplib::Client c("127.0.0.1", server.port);
    c.set_read_timeout(60, 0);
    c.Get("/api/events", [&](const char* data, size_t size) {
      events.append(data, size);
      size_t frames = 0;
      for (size_t at = events.find("event: frame"); at != std::string::npos;
           at = events.find("event: frame", at + 1)) {
        frames += events.find("\n\n", at) != std::string::npos;  // complete events only
      }
      return frames < 4;
    });
  });
  std::thread video_reader([&] {
    httplib::Client c("127.0.0.1", server.port);
    c.set_read_timeout(60, 0);
    c.Get("/api/stream.mjpeg", [&](const char* data, size_t size) {
      video.append(data, size);
      return video.find("--linesightframe", video.find("--linesightframe") + 1) ==
             std::string::npos;  // until a second part begins: the first is complete
    });
  });
  // Both viewers are connected before the first frame (the annotated view is drawn for viewers).
  for (int i = 0; i < 100 && station.Status()["frame"] == -1; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  station.Start();
  event_reader.join();
  video_reader.join();
  while (station.running()) station.WaitForFrame(station.Snapshot().frame_index, 1.0);
  EXPECT_EQ(station.error(), "");

  // The event stream: a status event first, then one frame event per frame, in order.
  EXPECT_EQ(events.rfind("retry: 1000\nevent: status\ndata: {", 0), 0u) << events.substr(0, 80);
  int64_t expected_frame = 0;
  for (size_t at = events.find("event: frame\ndata: "); at != std::string::npos;
       at = events.find("event: frame\ndata: ", at + 1)) {
    const size_t start = at + std::string("event: frame\ndata: ").size();
    const auto j = nlohmann::json::parse(events.substr(start, events.find('\n', start) - start));
    EXPECT_EQ(j["result"]["frame"], expected_frame++);
    EXPECT_TRUE(j["status"].contains("stages_ms"));
    EXPECT_GT(j["result"]["stages_ms"]["match"].get<double>(), 0);
  }
  EXPECT_EQ(expected_frame, 4);

  // The video: a multipart JPEG part of the annotated view.
  const std::string head = "Content-Type: image/jpeg\r\nContent-Length: ";
  const size_t at = video.find(head);
  ASSERT_NE(at, std::string::npos) << video.substr(0, 200);
  const size_t length = std::stoul(video.substr(at + head.size()));
  const size_t body = video.find("\r\n\r\n", at) + 4;
  ASSERT_LE(body + length, video.size());
  const cv::Mat frame = cv::imdecode(
      std::vector<uint8_t>(video.begin() + long(body), video.begin() + long(body + length)),
      cv::IMREAD_COLOR);
  EXPECT_EQ(frame.size(), cv::Size(752, 480));
  auto wrong_view = server.client.Get("/api/stream.mjpeg?view=depth");
  ASSERT_TRUE(wrong_view);
  EXPECT_EQ(wrong_view->status, 400);

  // Status: stage timing, the calibration's health (the true calibration: rows aligned).
  const nlohmann::json status = station.Status();
  for (const char* stage : {"grab", "rectify", "match", "range", "health", "encode", "latency"}) {
    EXPECT_TRUE(status["stages_ms"].contains(stage)) << stage;
  }
  EXPECT_GT(status["latency_ms"].get<double>(), status["stages_ms"]["match"].get<double>() * 0.5);
  EXPECT_EQ(status["stale"], false);
  EXPECT_EQ(status["calibration_health"]["verdict"], "good") << status["calibration_health"];
  EXPECT_LT(status["calibration_health"]["median_abs_row_offset_px"].get<double>(), 0.3);
  EXPECT_EQ(status["calibration_health"]["history"].size(), 4u);

  // The recording: four pairs and result lines, replayable through the images: source.
  auto stop = server.client.Post("/api/record", R"({"on": false})", "application/json");
  ASSERT_TRUE(stop);
  const auto recording = nlohmann::json::parse(stop->body)["recording"];
  EXPECT_EQ(recording["on"], false);
  EXPECT_EQ(recording["frames"], 4);
  const std::string dir = recording["dir"];
  const auto replay = OpenFrameSource("images:" + dir + "/left/*.png," + dir + "/right/*.png");
  int replayed = 0;
  while (replay->Read()) ++replayed;
  EXPECT_EQ(replayed, 4);
  EXPECT_NO_THROW(ReadStereoCalibration(dir + "/stereo.yml"));
  fs::remove_all(options.record_dir);
}

// The base station on the moving synthetic sequence (tuning seed 3, the robot 2 m from the first
// obstacle): the page's data lists the obstacles on the line with their type and distance along
// the line, nothing off the line, and the alarm distance set through the API turns the alarm on.
TEST(BaseStation, ListsTheObstaclesOnTheLineOfTheMovingSequence) {
  FrameSourceOptions source_options;
  source_options.synthetic_start_m = 2.0;
  BaseStationOptions options;
  options.max_frames = 6;
  BaseStation station(OpenFrameSource("synthetic:3", source_options), std::nullopt, options);
  LoopbackServer server(&station);
  httplib::Client& client = server.client;

  auto bad = client.Post("/api/alarm", R"({"distance_m": -1})", "application/json");
  ASSERT_TRUE(bad);
  EXPECT_EQ(bad->status, 400);
  EXPECT_NE(bad->body.find("distance_m"), std::string::npos) << bad->body;
  auto set = client.Post("/api/alarm", R"({"distance_m": 2.5})", "application/json");
  ASSERT_TRUE(set);
  ASSERT_EQ(set->status, 200);
  EXPECT_EQ(nlohmann::json::parse(set->body)["alarm_distance_m"], 2.5);
  EXPECT_EQ(nlohmann::json::parse(set->body)["finder"], "line");

  station.Start();
  while (station.running()) station.WaitForFrame(station.Snapshot().frame_index, 1.0);
  EXPECT_EQ(station.error(), "");
  auto result = client.Get("/api/result");
  ASSERT_TRUE(result);
  ASSERT_EQ(result->status, 200);
  const auto j = nlohmann::json::parse(result->body);
  ASSERT_TRUE(j.contains("line")) << result->body;
  const auto& line = j["line"];
  EXPECT_EQ(line["conductor"]["status"], "ok");
  EXPECT_FALSE(line["conductor"]["line"]["image_uvd"].empty());

  // The truth of the last frame, rendered from the same sequence.
  sim::PowerLineSequenceOptions truth_options;
  truth_options.seed = 3;
  truth_options.start_gap_m = 2.0;
  truth_options.scene.sensor.supersampling = 1;
  const sim::PowerLineScene truth =
      sim::PowerLineSequence(truth_options).Render(j["frame"].get<int>());
  const sim::RenderedObstacle* first = &truth.obstacles.front();
  for (const auto& o : truth.obstacles) {
    if (o.near_arc_m < first->near_arc_m) first = &o;
  }
  ASSERT_FALSE(line["tracks"].empty()) << line.dump();
  const auto& nearest = line["tracks"][0];
  EXPECT_EQ(nearest["type"], sim::ObstacleTypeName(first->type)) << nearest.dump();
  EXPECT_NEAR(nearest["arc_m"].get<double>(), first->near_arc_m, 0.05 * first->near_arc_m);
  EXPECT_GT(nearest["approach_mps"].get<double>(), 0.0);
  EXPECT_EQ(line["alarm"], nearest["arc_m"].get<double>() <= 2.5);
  EXPECT_EQ(line["alarm_distance_m"], 2.5);
  for (const auto& t : line["tracks"]) {
    const cv::Rect box(t["box"][0], t["box"][1], t["box"][2], t["box"][3]);
    bool on_an_obstacle = false;
    for (const auto& o : truth.obstacles) on_an_obstacle |= (box & o.box).area() > 0;
    EXPECT_TRUE(on_an_obstacle) << "a track that is not an obstacle of the scene: " << t.dump();
  }
}

// The conductor inspected live: a still pair of the synthetic line with a bird-cage 1.0 m along it
// (linesight inspect finds it at 0.99..1.04 m). Every frame finds it, the station keeps it as one
// fault at its true arc and serves its crop as a JPEG; names that are not a kept fault answer 404
// with the reason; with the inspection off the result says so.
TEST(BaseStation, ListsTheBirdcageOnTheLineWithItsCrop) {
  sim::PowerLineSceneOptions scene_options;
  scene_options.sensor.supersampling = 1;
  scene_options.obstacles.clear();
  scene_options.defects = sim::ParseDefectSpecs("birdcage:1.0");
  const sim::PowerLineScene scene = sim::RenderPowerLineScene(scene_options);
  ASSERT_EQ(scene.defects.size(), 1u);
  const sim::RenderedDefect& truth = scene.defects[0];
  const std::string l = ::testing::TempDir() + "/bs_birdcage_l.png";
  const std::string r = ::testing::TempDir() + "/bs_birdcage_r.png";
  ASSERT_TRUE(cv::imwrite(l, scene.left) && cv::imwrite(r, scene.right));
  BaseStationOptions options;
  options.max_frames = 3;
  options.overlap = false;
  BaseStation station(OpenFrameSource("pair:" + l + "," + r), scene.calibration, options);
  LoopbackServer server(&station);
  httplib::Client& client = server.client;
  auto none_yet = client.Get("/api/fault/1.jpg");
  ASSERT_TRUE(none_yet);
  EXPECT_EQ(none_yet->status, 404);
  EXPECT_NE(none_yet->body.find("no fault 1 is kept"), std::string::npos) << none_yet->body;

  station.Start();
  while (station.running()) station.WaitForFrame(station.Snapshot().frame_index, 1.0);
  EXPECT_EQ(station.error(), "");
  auto result = client.Get("/api/result");
  ASSERT_TRUE(result);
  ASSERT_EQ(result->status, 200);
  const auto j = nlohmann::json::parse(result->body);
  ASSERT_TRUE(j["line"].contains("inspection")) << result->body;
  const auto& inspection = j["line"]["inspection"];
  EXPECT_EQ(inspection["status"], "ok") << inspection.dump();
  EXPECT_GT(inspection["inspected_m"].get<double>(), 0.5);
  ASSERT_EQ(inspection["in_frame"].size(), 1u) << inspection.dump();
  ASSERT_EQ(inspection["faults"].size(), 1u) << inspection.dump();
  const auto& fault = inspection["faults"][0];
  EXPECT_EQ(fault["type"], "birdcage");
  EXPECT_EQ(inspection["in_frame"][0]["id"], fault["id"]);
  EXPECT_NEAR(fault["arc_m"].get<double>(), truth.arc_m, 0.1) << fault.dump();
  EXPECT_NEAR(fault["arc_now_m"].get<double>(), fault["arc_m"].get<double>(), 1e-9);  // still
  EXPECT_GT(fault["length_m"].get<double>(), 0.0);
  EXPECT_LT(fault["length_m"].get<double>(), 0.3);
  EXPECT_GT(fault["size_m"].get<double>(), 0.0);
  EXPECT_EQ(fault["sightings"], 3);
  EXPECT_EQ(fault["last_seen_frame"], 2);
  const cv::Rect box(fault["box"][0], fault["box"][1], fault["box"][2], fault["box"][3]);
  EXPECT_GT((box & truth.box).area(), 0) << fault.dump();
  EXPECT_GT(station.Status()["stages_ms"]["inspect"].get<double>(), 0.0);

  const std::string url = fault["crop"];
  EXPECT_EQ(url, fmt::format("/api/fault/{}.jpg", fault["id"].get<int>()));
  auto crop = client.Get(url);
  ASSERT_TRUE(crop);
  ASSERT_EQ(crop->status, 200) << crop->body;
  EXPECT_EQ(crop->get_header_value("Content-Type"), "image/jpeg");
  const cv::Mat decoded =
      cv::imdecode(std::vector<uint8_t>(crop->body.begin(), crop->body.end()), cv::IMREAD_COLOR);
  EXPECT_GE(decoded.cols, box.width);
  EXPECT_LE(std::max(decoded.cols, decoded.rows), options.fault_log.crop_max_px);

  for (const auto& [path, fragment] : std::vector<std::pair<std::string, std::string>>{
           {"/api/fault/99.jpg", "no fault 99 is kept"},
           {"/api/fault/abc.jpg", "expected <id>.jpg"},
           {"/api/fault/0.jpg", "expected <id>.jpg"},
           {"/api/fault/", "expected <id>.jpg"},
           {"/api/fault/1.jpg/x", "no such resource"}}) {
    auto bad = client.Get(path);
    ASSERT_TRUE(bad) << path;
    EXPECT_EQ(bad->status, 404) << path;
    EXPECT_NE(nlohmann::json::parse(bad->body)["error"].get<std::string>().find(fragment),
              std::string::npos)
        << path << " -> " << bad->body;
  }
  auto post = client.Post(url, "{}", "application/json");
  ASSERT_TRUE(post);
  EXPECT_EQ(post->status, 405);
  EXPECT_EQ(post->get_header_value("Allow"), "GET");

  // Switched off: the result says so and lists nothing.
  options.inspect = false;
  options.max_frames = 1;
  BaseStation off(OpenFrameSource("pair:" + l + "," + r), scene.calibration, options);
  EXPECT_TRUE(off.Step());
  const nlohmann::json off_result = off.Snapshot().result;
  EXPECT_EQ(off_result["line"]["inspection"]["status"], "off");
  EXPECT_TRUE(off_result["line"]["inspection"]["faults"].empty());
  EXPECT_EQ(off.Status()["inspect"], false);
}

}  // namespace
}  // namespace linesight
