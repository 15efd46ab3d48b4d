// Computes the isgm disparity of a rectified stereo pair and prints its density (the percentage of
// pixels with a disparity). Usage: disparity_density LEFT RIGHT
#include <cstdio>
#include <exception>

#include <linesight/io/image_io.h>
#include <linesight/stereo/matcher.h>

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: %s LEFT RIGHT\n", argv[0]);
    return 2;
  }
  try {
    const cv::Mat left = linesight::ReadImage(argv[1], linesight::ImageColor::kGray);
    const cv::Mat right = linesight::ReadImage(argv[2], linesight::ImageColor::kGray);
    linesight::MatcherOptions options;
    options.num_disparities = 128;  // full-size Middlebury pairs such as Aloe need more than 64
    const linesight::MatchResult result =
        linesight::CreateMatcher("isgm", options)->Compute(left, right);
    // isgm fills the pixels its SGM stage leaves out; `checked` holds only those it measured.
    std::printf("isgm density: %.1f %% (measured: %.1f %%)\n",
                linesight::DisparityDensity(result.disparity),
                linesight::DisparityDensity(result.checked));
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
