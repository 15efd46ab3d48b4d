// linesight: binocular stereo ranging. A table of subcommands; each one parses its options and
// calls the library (CONVENTIONS.md §13).
#include <cstdio>
#include <cstring>
#include <string_view>

#include "commands.h"
#include "linesight/core/process_memory.h"

namespace {

struct Subcommand {
  const char* name;
  int (*run)(int argc, char** argv);
  const char* summary;
};

constexpr Subcommand kSubcommands[] = {
    {"demo", linesight::cli::RunDemo,
     "the whole chain on the embedded synthetic power-line scene (true vs measured distance)"},
    {"disparity", linesight::cli::RunDisparity,
     "dense disparity of a stereo pair (PFM / KITTI PNG / colour)"},
    {"eval", linesight::cli::RunEval,
     "evaluation studies: stereo benchmarks, calibration, ranging"},
    {"rectify", linesight::cli::RunRectify,
     "rectify a raw stereo pair with a calibration (Bouguet)"},
    {"cloud", linesight::cli::RunCloud,
     "point cloud (PLY, metres) and depth PNG from a disparity map"},
    {"range", linesight::cli::RunRange,
     "distance +- sigma to obstacles in ROIs or found automatically"},
    {"inspect", linesight::cli::RunInspect,
     "the robot's conductor: radius profile, bird-caging, foreign objects and tilted dampers"},
    {"bench", linesight::cli::RunBench,
     "throughput of sgm / isgm vs OpenCV StereoSGBM (ms, fps, MDE/s, memory)"},
    {"render", linesight::cli::RunRender,
     "synthetic power-line scene + calibration boards with exact ground truth"},
    {"calibrate", linesight::cli::RunCalibrate,
     "stereo calibration from board images (zhang | recon | opencv)"},
    {"pattern", linesight::cli::RunPattern,
     "render an LCD calibration target with its exact square size"},
    {"serve", linesight::cli::RunServe,
     "base station: live ranging of a camera / video / synthetic stream, web page + JSON API"},
    {"acquire", linesight::cli::RunAcquire,
     "record stereo pairs from a camera, video or the synthetic scene (e.g. calibration views)"},
    {"batch", linesight::cli::RunBatch,
     "disparity / ranging of many recorded pairs in one process; resumable, shardable (Slurm)"},
};

void PrintUsage(std::FILE* out) {
  std::fprintf(out,
               "linesight - binocular stereo vision ranging\n\n"
               "usage: linesight <command> [options]   (linesight <command> --help for details)\n\n"
               "commands:\n");
  for (const Subcommand& c : kSubcommands) std::fprintf(out, "  %-11s %s\n", c.name, c.summary);
}

}  // namespace

int main(int argc, char** argv) {
  linesight::RetainFreedMemory();  // frame loops reuse their freed buffers (core/process_memory.h)
  if (argc < 2) {
    PrintUsage(stderr);
    return 2;
  }
  const std::string_view command = argv[1];
  if (command == "--help" || command == "-h" || command == "help") {
    PrintUsage(stdout);
    return 0;
  }
  if (command == "--version") {
    std::printf("linesight 0.1.0\n");
    return 0;
  }
  for (const Subcommand& c : kSubcommands) {
    if (command == c.name) return c.run(argc - 1, argv + 1);
  }
  std::fprintf(stderr, "linesight: unknown command '%s' (see linesight --help)\n", argv[1]);
  return 2;
}
