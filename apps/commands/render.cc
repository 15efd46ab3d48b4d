// linesight render: the synthetic power-line scene (and optionally calibration boards) with exact
// ground truth.
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>

#include <fmt/format.h>

#include "cli.h"
#include "commands.h"
#include "linesight/core/error.h"
#include "linesight/core/progress.h"
#include "linesight/core/timer.h"
#include "linesight/io/disparity_io.h"
#include "linesight/io/image_io.h"
#include "linesight/io/json_io.h"
#include "linesight/sim/power_line_scene.h"
#include "linesight/sim/power_line_sequence.h"

namespace linesight::cli {
namespace {

// "9x6:0.04" -> cols, rows, square_m.
sim::ChessboardOptions ParseBoard(const std::string& text) {
  sim::ChessboardOptions board;
  int cols = 0, rows = 0;
  double square = 0;
  char x = 0, colon = 0;
  char extra = 0;
  if (std::sscanf(text.c_str(), "%d%c%d%c%lf%c", &cols, &x, &rows, &colon, &square, &extra) != 5 ||
      (x != 'x' && x != 'X') || colon != ':') {
    throw UsageError(fmt::format("--board '{}': expected COLSxROWS:SQUARE_M, e.g. 9x6:0.04", text));
  }
  board.cols = cols;
  board.rows = rows;
  board.square_m = square;
  return board;
}

}  // namespace

int RunRender(int argc, char** argv) {
  CLI::App app{
      "Render the synthetic power-line scene seen by a MYNT S1030-like stereo rig: raw pair, true "
      "calibration, rectified ground-truth disparity/depth, obstacle masks and distances; "
      "optionally conductor defects (--defects) and calibration boards.",
      "render"};
  std::string out_dir, obstacles_text, defects_text, board_text = "9x6:0.04", json_path;
  sim::PowerLineSceneOptions options;
  std::uint64_t seed = options.seed;
  std::optional<std::uint64_t> noise_seed;
  bool no_towers = false;
  int boards = 0, boards_left_only = 0, boards_right_only = 0;
  std::optional<int> sequence_frames;
  sim::PowerLineSequenceOptions sequence_options;
  app.add_option("--out", out_dir, "output folder (created if missing)")->required();
  app.add_option("--seed", seed, "scene seed (textures, clouds) and default noise seed")
      ->capture_default_str();
  app.add_option("--noise-seed", noise_seed, "sensor noise seed (default: derived from --seed)");
  app.add_option("--obstacles", obstacles_text,
                 "type:distance_m[:conductor][:tilt=deg],... with type damper|clamp|insulator; "
                 "distance = nearest visible surface along the rectified optical axis; tilt = a "
                 "damaged damper turned about the line (-60..60 deg, > 0 to the right) (default "
                 "damper:1.5,clamp:3,insulator:4.5; 'none' for no obstacles)");
  app.add_option(
      "--defects", defects_text,
      "defects of conductor 0, type:arc_m[:key=value]...,... with arc_m the arc length of the "
      "centre from the point of the line nearest the camera; types and keys: birdcage "
      "(swelling=0.05..1 relative radius increase, length=0.03..0.5 m), broken_strands "
      "(strands=1..3, standoff=0.002..0.08 m, angle=deg around the line, 0 = down, 90 = side, "
      "180 = up), string (length=0.03..1.5 m hanging, angle), sheet (length=0.03..0.6 m side, "
      "angle), nest (length=0.05..0.6 m diameter); e.g. "
      "birdcage:2:swelling=0.3:length=0.15,string:3.1:length=0.4 (writes defects.json, "
      "defect_mask.png)");
  app.add_option("--noise", options.sensor.noise_sigma_dn, "Gaussian read noise sigma (DN)")
      ->capture_default_str();
  app.add_option("--shot-noise", options.sensor.shot_noise_electrons,
                 "shot noise: electrons at full scale (0 = off)")
      ->capture_default_str();
  app.add_option("--blur", options.sensor.blur_sigma_px, "Gaussian optical blur sigma (px)")
      ->capture_default_str();
  app.add_option("--exposure", options.sensor.exposure, "exposure multiplier")
      ->capture_default_str();
  app.add_option("--right-gain", options.sensor.right_gain,
                 "gain of the right camera relative to the left")
      ->capture_default_str();
  app.add_option("--vignetting", options.sensor.vignetting, "fall-off at the image corner (0..0.9)")
      ->capture_default_str();
  app.add_option("--supersampling", options.sensor.supersampling, "SxS rays per pixel (1..8)")
      ->capture_default_str();
  app.add_option("--conductors", options.num_conductors, "number of conductors (1..4)")
      ->capture_default_str();
  app.add_option("--clouds", options.cloud_cover, "cloud cover 0..1")->capture_default_str();
  AddLineGeometryOptions(app, &options.conductor_offset_x_m, &options.conductor_offset_y_m,
                         &options.conductor_yaw_rad, &options.tower_offset_x_m);
  app.add_flag("--no-towers", no_towers, "leave out the lattice towers");
  app.add_flag("--rectified", options.render_rectified_pair,
               "also ray cast an ideal rectified pair (rectified_left/right.png)");
  app.add_option("--boards", boards,
                 "also render N calibration board views seen by both cameras into OUT/boards")
      ->capture_default_str();
  app.add_option("--boards-left-only", boards_left_only,
                 "board views fully seen by the left camera only")
      ->capture_default_str();
  app.add_option("--boards-right-only", boards_right_only,
                 "board views fully seen by the right camera only")
      ->capture_default_str();
  app.add_option("--board", board_text, "chessboard COLSxROWS:SQUARE_M (inner corners, metres)")
      ->capture_default_str();
  app.add_option("--sequence", sequence_frames,
                 "render a moving sequence instead: the robot rides toward the seed's obstacles; "
                 "N frames (0 = the whole approach), written as left_NNNN.png, right_NNNN.png, "
                 "truth.jsonl");
  app.add_option("--speed", sequence_options.speed_mps,
                 "sequence: robot speed along the line (m/s)")
      ->capture_default_str();
  app.add_option("--fps", sequence_options.fps, "sequence: frame rate (Hz)")->capture_default_str();
  app.add_option("--start", sequence_options.start_gap_m,
                 "sequence: arc from the robot to the first obstacle's near end at frame 0 (m)")
      ->capture_default_str();
  app.add_option("--num-obstacles", sequence_options.num_obstacles,
                 "sequence: obstacles on the line (types and gaps from --seed)")
      ->capture_default_str();
  app.add_option("--num-defects", sequence_options.num_defects,
                 "sequence: defects of conductor 0 (0..6; types, sizes and arcs between the start "
                 "and the last obstacle from --seed; per-frame truth under \"defects\" in "
                 "truth.jsonl)")
      ->capture_default_str();
  app.add_option("--tilted-dampers", sequence_options.tilted_damper_share,
                 "sequence: share of the dampers turned about the line by 10..25 deg (0..1)")
      ->capture_default_str();
  app.add_option("--json", json_path, "machine-readable report (- for stdout)");
  return RunCommand(app, argc, argv, [&] {
    if (sequence_frames) {
      if (!obstacles_text.empty() || boards + boards_left_only + boards_right_only > 0) {
        throw UsageError("--sequence draws its obstacles from --seed: drop --obstacles/--boards");
      }
      if (!defects_text.empty()) {
        throw UsageError(
            "--sequence draws its defects from --seed: use --num-defects, not --defects");
      }
      options.towers = !no_towers;
      sequence_options.scene = options;
      sequence_options.seed = seed;
      Stopwatch watch;
      const sim::PowerLineSequence sequence(sequence_options);
      const int count =
          *sequence_frames == 0 ? sequence.size() : std::min(*sequence_frames, sequence.size());
      CheckOption(*sequence_frames >= 0, "--sequence", *sequence_frames, "must be >= 0");
      ProgressBar bar(count, "render");
      sim::WritePowerLineSequence(out_dir, sequence, count, [&](int, int) { bar.Advance(); });
      bar.Finish();
      std::fprintf(stderr,
                   "render: %d frames (%.1f s at %.3g m/s, %.3g fps) in %.1f s, written to %s\n",
                   count, sequence.TimestampOf(count - 1), sequence_options.speed_mps,
                   sequence_options.fps, watch.ElapsedMs() / 1000.0, out_dir.c_str());
      for (const sim::SequenceLayoutEntry& e : sequence.layout()) {
        std::fprintf(
            stdout, "%-10s centre at %.3f m of arc from the start%s\n",
            sim::ObstacleTypeName(e.type).c_str(), e.arc_m,
            e.tilt_deg != 0 ? fmt::format(", tilted {:+.1f} deg", e.tilt_deg).c_str() : "");
      }
      for (const sim::DefectSpec& d : sequence.defects()) {
        std::fprintf(stdout, "%-14s defect centre at %.3f m of arc from the start\n",
                     sim::DefectTypeName(d.type).c_str(), d.arc_m);
      }
      if (!json_path.empty()) {
        nlohmann::json report;
        report["out"] = out_dir;
        report["frames"] = count;
        report["seed"] = seed;
        nlohmann::json layout = nlohmann::json::array();
        for (const sim::SequenceLayoutEntry& e : sequence.layout()) {
          layout.push_back({{"type", sim::ObstacleTypeName(e.type)}, {"arc_m", e.arc_m}});
          if (e.tilt_deg != 0) layout.back()["tilt_deg"] = e.tilt_deg;
        }
        report["layout"] = layout;
        if (!sequence.defects().empty()) {
          nlohmann::json defects = nlohmann::json::array();
          for (const sim::DefectSpec& d : sequence.defects()) {
            defects.push_back({{"type", sim::DefectTypeName(d.type)}, {"arc_m", d.arc_m}});
          }
          report["defects"] = defects;
        }
        WriteJson(json_path, report);
      }
      return;
    }
    if (sequence_options.num_defects != 0) {
      throw UsageError("--num-defects is for --sequence; a still scene takes --defects");
    }
    if (sequence_options.tilted_damper_share != 0) {
      throw UsageError("--tilted-dampers is for --sequence; a still scene takes damper:D:tilt=deg");
    }
    options.seed = seed;
    options.sensor.noise_seed = noise_seed;
    options.towers = !no_towers;
    if (obstacles_text == "none") {
      options.obstacles.clear();
    } else if (!obstacles_text.empty()) {
      options.obstacles = sim::ParseObstacleSpecs(obstacles_text);
    }
    if (!defects_text.empty()) options.defects = sim::ParseDefectSpecs(defects_text);
    options.Check();
    sim::CalibrationBoardOptions board_options;
    const bool want_boards = boards + boards_left_only + boards_right_only > 0;
    if (want_boards) {
      board_options.rig = options.rig;
      board_options.board = ParseBoard(board_text);
      board_options.seed = seed;
      board_options.num_stereo_views = boards;
      board_options.num_left_only = boards_left_only;
      board_options.num_right_only = boards_right_only;
      board_options.sensor = options.sensor;
      board_options.sensor.supersampling = std::max(4, options.sensor.supersampling);
      board_options.Check();
    }

    Stopwatch watch;
    const sim::PowerLineScene scene = sim::RenderPowerLineScene(options);
    const double scene_ms = watch.ElapsedMs();
    const std::filesystem::path dir(out_dir);
    sim::WritePowerLineScene(dir, scene);
    float max_disparity = 0;
    for (const sim::RenderedObstacle& o : scene.obstacles) {
      max_disparity = std::max(max_disparity, scene.disparity.at<float>(o.nearest_pixel));
    }
    WriteImage(dir / "disparity_gt_color.png",
               ColorizeDisparityWithLegend(scene.disparity, 0.0f, std::max(16.0f, max_disparity)));

    double boards_ms = 0;
    std::size_t board_views = 0;
    if (want_boards) {
      Stopwatch board_watch;
      const sim::CalibrationBoardSet set = sim::RenderCalibrationBoards(board_options);
      boards_ms = board_watch.ElapsedMs();
      board_views = set.views.size();
      sim::WriteCalibrationBoards(dir / "boards", set);
    }

    // The table goes to stdout unless the JSON report does.
    std::FILE* table = json_path == "-" ? stderr : stdout;
    std::fprintf(table, "%-3s %-10s %12s %10s %22s %8s\n", "id", "type", "distance_m", "requested",
                 "box (x,y,w,h)", "pixels");
    for (const sim::RenderedObstacle& o : scene.obstacles) {
      std::fprintf(table, "%-3d %-10s %12.6f %10.3f %22s %8d\n", o.id,
                   sim::ObstacleTypeName(o.type).c_str(), o.distance_m, o.requested_distance_m,
                   fmt::format("{},{},{},{}", o.box.x, o.box.y, o.box.width, o.box.height).c_str(),
                   o.visible_pixels);
    }
    if (!scene.defects.empty()) {
      std::fprintf(table, "%-3s %-14s %8s %16s %12s %10s %22s %8s\n", "id", "defect", "arc_m",
                   "extent_m", "size_m", "distance_m", "box (x,y,w,h)", "pixels");
      for (const sim::RenderedDefect& d : scene.defects) {
        std::fprintf(
            table, "%-3d %-14s %8.3f %16s %12.4f %10.4f %22s %8d\n", d.id,
            sim::DefectTypeName(d.type).c_str(), d.arc_m,
            fmt::format("{:.3f}..{:.3f}", d.arc_begin_m, d.arc_end_m).c_str(), d.size_m,
            d.distance_m,
            fmt::format("{},{},{},{}", d.box.x, d.box.y, d.box.width, d.box.height).c_str(),
            d.visible_pixels);
      }
    }
    std::fprintf(stderr, "render: scene %.0f ms%s, written to %s\n", scene_ms,
                 want_boards
                     ? fmt::format(", {} board views {:.0f} ms", board_views, boards_ms).c_str()
                     : "",
                 dir.string().c_str());
    if (!json_path.empty()) {
      nlohmann::json report = sim::ObstaclesToJson(scene.obstacles);
      report["out"] = dir.string();
      report["seed"] = seed;
      report["image_size"] = {scene.left.cols, scene.left.rows};
      report["baseline_m"] = scene.calibration.Baseline();
      report["rectified_focal_px"] = scene.calibration.RectifiedFocal();
      report["scene_ms"] = scene_ms;
      report["board_views"] = board_views;
      report["boards_ms"] = boards_ms;
      if (!scene.defects.empty()) report["defects"] = sim::DefectsToJson(scene.defects)["defects"];
      WriteJson(json_path, report);
    }
  });
}

}  // namespace linesight::cli
