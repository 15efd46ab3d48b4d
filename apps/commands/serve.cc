// linesight serve: the base station. Ranges a live stereo stream and serves the web page and JSON
// API (src/linesight/server/base_station.h) that show it.
#include <pthread.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <optional>
#include <thread>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "cli.h"
#include "commands.h"
#include "linesight/acquire/frame_source.h"
#include "linesight/core/error.h"
#include "linesight/io/stereo_calibration.h"
#include "linesight/ranging/ranging.h"
#include "linesight/server/base_station.h"
#include "linesight/stereo/matcher.h"

namespace linesight::cli {
namespace {

using namespace std::chrono_literals;

bool IsLoopback(const std::string& host) {
  return host == "localhost" || host == "::1" || host.rfind("127.", 0) == 0;
}

// The access token: --token, or the first line of --token-file (the file keeps it out of the
// process list). UsageError when both are given; InputError naming the file when it is unreadable
// or empty.
std::string ReadToken(const std::string& token, const std::string& token_file) {
  if (token_file.empty()) return token;
  if (!token.empty()) throw UsageError("give --token or --token-file, not both");
  std::ifstream in(token_file);
  std::string line;
  if (!in || !std::getline(in, line)) {
    throw InputError(fmt::format("{}: cannot read the access token", token_file));
  }
  while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
  if (line.empty()) throw InputError(fmt::format("{}: the access token is empty", token_file));
  return line;
}

}  // namespace

int RunServe(int argc, char** argv) {
  CLI::App app{
      "Base station: find the obstacles on the robot's line in a live stereo stream (camera, "
      "video, images or the moving synthetic sequence), range them and any ROI, and serve a web "
      "page and JSON API with each obstacle's type, distance along the line and straight +- "
      "sigma, approach rate, time to reach and the alarm.",
      "serve"};
  std::string source_spec, calib_path, host = "127.0.0.1";
  std::vector<std::string> roi_texts, raw_params;
  int port = 8080;
  bool no_auto = false;
  std::string finder = "line";
  FrameSourceOptions source_options;
  BaseStationOptions options;
  AddSourceOptions(app, &source_spec, &source_options);
  app.add_option("--calib", calib_path,
                 "stereo calibration (OpenCV YAML; default: the source's own, e.g. synthetic)");
  app.add_option("--host", host, "address to listen on (0.0.0.0 = every interface)")
      ->capture_default_str();
  app.add_option("--port", port, "TCP port (0 = any free port)")->capture_default_str();
  std::string token, token_file;
  app.add_option("--token", token,
                 "access token every change (POST) must carry as 'Authorization: Bearer TOKEN'; "
                 "required with a --host other than loopback (open the page as "
                 "http://HOST:PORT/#token=TOKEN)");
  app.add_option("--token-file", token_file, "read the access token from this file's first line");
  app.add_option("--roi", roi_texts, "region x,y,w,h in rectified left pixels (repeatable)");
  app.add_flag("--no-auto", no_auto, "do not find obstacles automatically (only the ROIs)");
  app.add_option("--finder", finder,
                 "automatic finding: line (the obstacles on the robot's conductor, typed, along "
                 "the line) or regions (every region thicker than a conductor, for any rig)")
      ->capture_default_str();
  app.add_flag("--inspect,!--no-inspect", options.inspect,
               "line finder: inspect the conductor in every frame (bird-caging) and list the "
               "faults seen recently with a crop each (default on)");
  app.add_option("--alarm-distance", options.alarm_distance_m,
                 "alarm when an obstacle on the line is nearer than this along the line (m)")
      ->capture_default_str();
  app.add_flag("--rectified", options.pipeline.input_rectified,
               "the frames are already rectified (P1 P2 Q as given)");
  app.add_option("--method", options.pipeline.method,
                 fmt::format("matcher: {} (default {})", fmt::join(MatcherNames(), ", "),
                             DefaultMatcherName()));
  AddParamOption(app, &raw_params);
  app.add_option("--min-depth", options.pipeline.min_depth_m, "working range: nearest depth (m)")
      ->capture_default_str();
  app.add_option("--max-depth", options.pipeline.max_depth_m, "working range: farthest depth (m)")
      ->capture_default_str();
  app.add_option("--threads", options.pipeline.threads, "matcher threads (0 = all cores)")
      ->capture_default_str();
  app.add_option("--max-fps", options.max_fps, "processing rate cap (0 = as fast as possible)")
      ->capture_default_str();
  app.add_option("--frames", options.max_frames,
                 "stop processing after N frames (0 = until the source ends); the page stays up")
      ->capture_default_str();
  bool no_overlap = false;
  app.add_flag("--no-overlap", no_overlap,
               "process one frame at a time (default: grab and match the next pair while this one "
               "is ranged and published)");
  app.add_option("--record-dir", options.record_dir,
                 "folder under which the page's record switch (POST /api/record) starts recordings "
                 "of the raw pairs and results, replayable with --source images:")
      ->capture_default_str();
  app.add_option("--health-every", options.health_every_frames,
                 "measure the calibration's health (row alignment) every N frames")
      ->capture_default_str();
  app.add_option("--jpeg-quality", options.jpeg_quality, "quality of the images sent to the page")
      ->capture_default_str();
  return RunCommand(app, argc, argv, [&] {
    for (const std::string& text : roi_texts) options.rois.push_back(ParseRoi(text));
    options.auto_detect = !no_auto;
    options.overlap = !no_overlap;
    options.finder = ParseAutoFinder(finder);
    options.pipeline.params = ParseParams(raw_params);
    if (options.rois.empty() && !options.auto_detect) {
      throw UsageError("--no-auto needs at least one --roi x,y,w,h");
    }
    BaseStationServerOptions server_options;
    server_options.token = ReadToken(token, token_file);
    if (!IsLoopback(host) && server_options.token.empty()) {
      throw UsageError(fmt::format(
          "--host {} is reachable from other machines: give an access token (--token or "
          "--token-file), or listen on 127.0.0.1",
          host));
    }
    // SIGINT and SIGTERM are taken by sigwait below, never by a handler: every thread started
    // from here on inherits the blocked mask.
    sigset_t stop_signals;
    sigemptyset(&stop_signals);
    sigaddset(&stop_signals, SIGINT);
    sigaddset(&stop_signals, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);
    std::optional<StereoCalibration> calib;
    if (!calib_path.empty()) calib = ReadStereoCalibration(calib_path);
    std::fprintf(stderr, "opening %s ...\n", source_spec.c_str());
    BaseStation station(OpenFrameSource(source_spec, source_options), calib, options);
    BaseStationServer server(&station, server_options);
    const int bound = server.Bind(host, port);
    const nlohmann::json status = station.Status();
    std::fprintf(stderr, "source: %s\ncalibration: %s\nmatcher %s over disparities %d..%d\n",
                 status["source"].get<std::string>().c_str(),
                 status["calibration"].get<std::string>().c_str(),
                 status["method"].get<std::string>().c_str(),
                 status["searched_disparities"][0].get<int>(),
                 status["searched_disparities"][1].get<int>());
    // The port line goes to stdout (scripts read it); everything else to stderr.
    std::cout << fmt::format("serving http://{}:{}/ (Ctrl-C stops)", host, bound) << std::endl;
    station.Start();
    std::thread http([&] { server.Listen(); });
    int signal_number = 0;
    sigwait(&stop_signals, &signal_number);
    const auto signalled = std::chrono::steady_clock::now();
    std::fprintf(stderr, "%s: stopping\n", signal_number == SIGINT ? "SIGINT" : "SIGTERM");
    // The loop first (requests waiting for its next frame return at once), then the server, which
    // closes stalled connections within its I/O timeout.
    station.RequestStop();
    server.Stop();
    http.join();
    // A frame still in the matcher is not waited for beyond 1 s after the signal: the process
    // ends without it (it holds nothing that outlives the process).
    while (station.running() && std::chrono::steady_clock::now() - signalled < 1000ms) {
      std::this_thread::sleep_for(10ms);
    }
    if (station.running()) {
      std::fprintf(stderr, "stopped without waiting for the frame in progress\n");
      std::fflush(nullptr);
      std::_Exit(0);
    }
    station.Stop();
    if (!station.error().empty()) throw InputError(station.error());
  });
}

}  // namespace linesight::cli
