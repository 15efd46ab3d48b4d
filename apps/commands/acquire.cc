// linesight acquire: record stereo pairs from any frame source (e.g. calibration views from the
// robot's camera).
#include <filesystem>
#include <iostream>
#include <optional>

#include <fmt/format.h>

#include "cli.h"
#include "commands.h"
#include "linesight/acquire/frame_source.h"
#include "linesight/core/error.h"
#include "linesight/core/progress.h"
#include "linesight/io/image_io.h"

namespace linesight::cli {

int RunAcquire(int argc, char** argv) {
  CLI::App app{
      "Record stereo pairs from a source (camera, video, images, synthetic) as left_NNNN.png / "
      "right_NNNN.png, e.g. calibration views.",
      "acquire"};
  std::string source_spec, out_dir;
  int64_t frames = 1;
  int every = 1;
  FrameSourceOptions source_options;
  AddSourceOptions(app, &source_spec, &source_options);
  app.add_option("--out", out_dir, "output folder (created if missing)")->required();
  app.add_option("--frames", frames, "pairs to write (>= 1)")->capture_default_str();
  app.add_option("--every", every, "keep every N-th pair (>= 1)")->capture_default_str();
  return RunCommand(app, argc, argv, [&] {
    if (frames < 1) throw UsageError(fmt::format("--frames {}: must be >= 1", frames));
    if (every < 1) throw UsageError(fmt::format("--every {}: must be >= 1", every));
    auto source = OpenFrameSource(source_spec, source_options);
    std::filesystem::create_directories(out_dir);
    ProgressBar progress(frames, "acquiring");
    int64_t written = 0;
    while (written < frames) {
      const std::optional<StereoFrame> frame = source->Read();
      if (!frame) break;
      if (frame->index % every != 0) continue;
      const std::string stem = fmt::format("{:04d}.png", written);
      WriteImage(std::filesystem::path(out_dir) / ("left_" + stem), frame->left);
      WriteImage(std::filesystem::path(out_dir) / ("right_" + stem), frame->right);
      ++written;
      progress.Advance(1, stem);
    }
    progress.Finish();
    std::cout << fmt::format("{} pairs from {} written to {}\n", written, source->Describe(),
                             out_dir);
    if (written == 0) throw InputError(fmt::format("{} delivered no frame", source->Describe()));
  });
}

}  // namespace linesight::cli
