#include "linesight/stereo/opencv_matchers.h"

#include <fmt/format.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/utility.hpp>

#include "linesight/core/error.h"
#include "linesight/core/scoped_threads.h"
#include "linesight/io/opencv_plugin.h"

namespace linesight {
namespace {

// OpenCV wants a multiple of 16; we search the next one up and cut the result back to the request.
int RoundUpTo16(int n) { return (n + 15) / 16 * 16; }

// Defaults of the --param keys (the docs below print them).
struct BmDefaults {
  int block = 15, uniqueness = 15, texture = 10, speckle_window = 100, speckle_range = 2,
      prefilter_cap = 31;
};
// OpenCV's stereo_match sample settings for a grey image; p1 and p2 scale with block.
struct SgbmDefaults {
  const char* mode = "3way";
  int block = 5, uniqueness = 10, speckle_window = 100, speckle_range = 2, disp12_max_diff = 1,
      prefilter_cap = 63;
  static int P1(int block) { return 8 * block * block; }
  static int P2(int block) { return 32 * block * block; }
};
struct WlsDefaults {
  double lambda = 8000.0, sigma = 1.5;
};

void CheckPair(const cv::Mat& left, const cv::Mat& right) {
  if (left.empty() || right.empty()) throw InputError("matcher input image is empty");
  if (left.size() != right.size()) {
    throw InputError(fmt::format("left image is {}x{} but right image is {}x{}", left.cols,
                                 left.rows, right.cols, right.rows));
  }
}

// An OpenCV matcher on the grey pair, with OpenCV's pool sized for the call; its fixed-point map
// in our encoding (no checks beyond its own, so `checked` is the same map).
MatchResult ComputeWithOpenCv(cv::StereoMatcher& matcher, const MatcherOptions& options,
                              const cv::Mat& left, const cv::Mat& right) {
  CheckPair(left, right);
  const ScopedOpenCvThreads threads(options.threads);
  cv::Mat fixed;
  matcher.compute(ToGray8(left), ToGray8(right), fixed);
  const cv::Mat disparity =
      FixedPointToFloatDisparity(fixed, options.min_disparity, options.num_disparities);
  return {disparity, disparity};
}

class OpenCvBlockMatcher final : public StereoMatcher {
 public:
  OpenCvBlockMatcher(const MatcherOptions& options, MatcherParams& params) : options_(options) {
    const BmDefaults d;
    block_ = params.GetInt("block", d.block);
    uniqueness_ = params.GetInt("uniqueness", d.uniqueness);
    texture_ = params.GetInt("texture", d.texture);
    speckle_window_ = params.GetInt("speckle_window", d.speckle_window);
    speckle_range_ = params.GetInt("speckle_range", d.speckle_range);
    prefilter_cap_ = params.GetInt("prefilter_cap", d.prefilter_cap);
    CheckOption(block_ >= 5 && block_ <= 255 && block_ % 2 == 1, "bm.block", block_,
                "must be odd and in [5, 255]");
    CheckOption(uniqueness_ >= 0, "bm.uniqueness", uniqueness_, "must be >= 0");
    CheckOption(texture_ >= 0, "bm.texture", texture_, "must be >= 0");
    CheckOption(speckle_window_ >= 0, "bm.speckle_window", speckle_window_, "must be >= 0");
    CheckOption(speckle_range_ >= 0, "bm.speckle_range", speckle_range_, "must be >= 0");
    CheckOption(prefilter_cap_ >= 1 && prefilter_cap_ <= 63, "bm.prefilter_cap", prefilter_cap_,
                "must be in [1, 63]");
    bm_ = cv::StereoBM::create(RoundUpTo16(options_.num_disparities), block_);
    bm_->setMinDisparity(options_.min_disparity);
    bm_->setUniquenessRatio(uniqueness_);
    bm_->setTextureThreshold(texture_);
    bm_->setSpeckleWindowSize(speckle_window_);
    bm_->setSpeckleRange(speckle_range_ * 16);
    bm_->setPreFilterCap(prefilter_cap_);
    bm_->setDisp12MaxDiff(1);
  }

  std::string Name() const override { return "bm"; }

  MatchResult Compute(const cv::Mat& left, const cv::Mat& right) override {
    return ComputeWithOpenCv(*bm_, options_, left, right);
  }

  nlohmann::json Settings() const override {
    return {{"method", "bm"},
            {"min_disparity", options_.min_disparity},
            {"num_disparities", options_.num_disparities},
            {"block", block_},
            {"uniqueness", uniqueness_},
            {"texture", texture_},
            {"speckle_window", speckle_window_},
            {"speckle_range", speckle_range_},
            {"prefilter_cap", prefilter_cap_}};
  }

 private:
  MatcherOptions options_;
  int block_, uniqueness_, texture_, speckle_window_, speckle_range_, prefilter_cap_;
  cv::Ptr<cv::StereoBM> bm_;
};

class OpenCvSgbm final : public StereoMatcher {
 public:
  OpenCvSgbm(const MatcherOptions& options, MatcherParams& params) : options_(options) {
    const SgbmDefaults d;
    mode_ = params.GetString("mode", d.mode, {"sgbm", "hh", "3way", "hh4"});
    block_ = params.GetInt("block", d.block);
    p1_ = params.GetInt("p1", SgbmDefaults::P1(block_));
    p2_ = params.GetInt("p2", SgbmDefaults::P2(block_));
    uniqueness_ = params.GetInt("uniqueness", d.uniqueness);
    speckle_window_ = params.GetInt("speckle_window", d.speckle_window);
    speckle_range_ = params.GetInt("speckle_range", d.speckle_range);
    disp12_max_diff_ = params.GetInt("disp12_max_diff", d.disp12_max_diff);
    prefilter_cap_ = params.GetInt("prefilter_cap", d.prefilter_cap);
    CheckOption(block_ >= 1 && block_ <= 31 && block_ % 2 == 1, "sgbm.block", block_,
                "must be odd and in [1, 31]");
    CheckOption(p1_ >= 0, "sgbm.p1", p1_, "must be >= 0");
    CheckOption(p2_ > p1_, "sgbm.p2", p2_, "must be > p1");
    CheckOption(uniqueness_ >= 0, "sgbm.uniqueness", uniqueness_, "must be >= 0");
    CheckOption(speckle_window_ >= 0, "sgbm.speckle_window", speckle_window_, "must be >= 0");
    CheckOption(speckle_range_ >= 0, "sgbm.speckle_range", speckle_range_, "must be >= 0");
    CheckOption(prefilter_cap_ >= 1, "sgbm.prefilter_cap", prefilter_cap_, "must be >= 1");
    const int mode = mode_ == "sgbm"  ? cv::StereoSGBM::MODE_SGBM
                     : mode_ == "hh"  ? cv::StereoSGBM::MODE_HH
                     : mode_ == "hh4" ? cv::StereoSGBM::MODE_HH4
                                      : cv::StereoSGBM::MODE_SGBM_3WAY;
    sgbm_ = cv::StereoSGBM::create(options_.min_disparity, RoundUpTo16(options_.num_disparities),
                                   block_, p1_, p2_, disp12_max_diff_, prefilter_cap_, uniqueness_,
                                   speckle_window_, speckle_range_ * 16, mode);
  }

  std::string Name() const override { return "sgbm"; }
  const cv::Ptr<cv::StereoSGBM>& matcher() const { return sgbm_; }

  MatchResult Compute(const cv::Mat& left, const cv::Mat& right) override {
    return ComputeWithOpenCv(*sgbm_, options_, left, right);
  }

  nlohmann::json Settings() const override {
    return {{"method", "sgbm"},
            {"mode", mode_},
            {"min_disparity", options_.min_disparity},
            {"num_disparities", options_.num_disparities},
            {"block", block_},
            {"p1", p1_},
            {"p2", p2_},
            {"uniqueness", uniqueness_},
            {"speckle_window", speckle_window_},
            {"speckle_range", speckle_range_},
            {"disp12_max_diff", disp12_max_diff_},
            {"prefilter_cap", prefilter_cap_}};
  }

 private:
  MatcherOptions options_;
  std::string mode_;
  int block_, p1_, p2_, uniqueness_, speckle_window_, speckle_range_, disp12_max_diff_,
      prefilter_cap_;
  cv::Ptr<cv::StereoSGBM> sgbm_;
};

// SGBM followed by ximgproc's DisparityWLSFilter guided by the left image, with the right-view
// matcher for the left-right confidence: what many OpenCV users pick for dense maps.
class OpenCvSgbmWls final : public StereoMatcher {
 public:
  OpenCvSgbmWls(const MatcherOptions& options, MatcherParams& params)
      : options_(options), sgbm_(options, params) {
    const WlsDefaults d;
    lambda_ = params.GetDouble("lambda", d.lambda);
    sigma_ = params.GetDouble("sigma", d.sigma);
    CheckOption(lambda_ >= 0, "sgbm-wls.lambda", lambda_, "must be >= 0");
    CheckOption(sigma_ > 0, "sgbm-wls.sigma", sigma_, "must be > 0");
    wls_ = LoadOpenCvPlugin("the sgbm-wls matcher").CreateSgbmWls(sgbm_.matcher(), lambda_, sigma_);
  }

  std::string Name() const override { return "sgbm-wls"; }

  MatchResult Compute(const cv::Mat& left, const cv::Mat& right) override {
    CheckPair(left, right);
    const ScopedOpenCvThreads threads(options_.threads);
    const cv::Mat left_gray = ToGray8(left), right_gray = ToGray8(right);
    cv::Mat filtered;
    wls_->Compute(left_gray, right_gray, left, right, &filtered);
    const cv::Mat disparity =
        FixedPointToFloatDisparity(filtered, options_.min_disparity, options_.num_disparities);
    return {disparity, disparity};
  }

  nlohmann::json Settings() const override {
    nlohmann::json settings = sgbm_.Settings();
    settings["method"] = "sgbm-wls";
    settings["lambda"] = lambda_;
    settings["sigma"] = sigma_;
    return settings;
  }

 private:
  MatcherOptions options_;
  OpenCvSgbm sgbm_;
  double lambda_, sigma_;
  std::unique_ptr<SgbmWlsHandle> wls_;
};

}  // namespace

std::vector<MatcherParamDoc> OpenCvBlockMatcherParamDocs() {
  const BmDefaults d;
  return {
      {"block", "int", ParamDefault(d.block), "matched block side (px, odd, 5..255)"},
      {"uniqueness", "int", ParamDefault(d.uniqueness),
       "uniqueness ratio (%): the winner must beat every other disparity by this margin"},
      {"texture", "int", ParamDefault(d.texture),
       "minimum texture of a block (sum of prefiltered values); below it no estimate"},
      {"speckle_window", "int", ParamDefault(d.speckle_window),
       "largest blob of similar disparities removed as a speckle (px); 0 = off"},
      {"speckle_range", "int", ParamDefault(d.speckle_range),
       "largest disparity step inside one speckle blob (px)"},
      {"prefilter_cap", "int", ParamDefault(d.prefilter_cap),
       "clip of the normalised prefiltered image (1..63)"},
  };
}

std::vector<MatcherParamDoc> OpenCvSgbmParamDocs() {
  const SgbmDefaults d;
  return {
      {"mode", "sgbm|hh|3way|hh4", d.mode,
       "OpenCV StereoSGBM mode: MODE_SGBM, MODE_HH (full 8 paths), MODE_SGBM_3WAY, MODE_HH4"},
      {"block", "int", ParamDefault(d.block), "matched block side (px, odd, 1..31)"},
      {"p1", "int", ParamDefault(SgbmDefaults::P1(d.block)),
       "penalty for a disparity change of +-1 px between neighbours; default 8*block^2"},
      {"p2", "int", ParamDefault(SgbmDefaults::P2(d.block)),
       "penalty for a larger disparity change (> p1); default 32*block^2"},
      {"uniqueness", "int", ParamDefault(d.uniqueness),
       "uniqueness ratio (%): the winner must beat every other disparity by this margin"},
      {"speckle_window", "int", ParamDefault(d.speckle_window),
       "largest blob of similar disparities removed as a speckle (px); 0 = off"},
      {"speckle_range", "int", ParamDefault(d.speckle_range),
       "largest disparity step inside one speckle blob (px)"},
      {"disp12_max_diff", "int", ParamDefault(d.disp12_max_diff),
       "largest left-right check difference (px); < 0 = no check"},
      {"prefilter_cap", "int", ParamDefault(d.prefilter_cap),
       "clip of the x-derivative prefilter (>= 1)"},
  };
}

std::vector<MatcherParamDoc> OpenCvSgbmWlsParamDocs() {
  const WlsDefaults d;
  std::vector<MatcherParamDoc> docs = OpenCvSgbmParamDocs();
  docs.push_back({"lambda", "number", ParamDefault(d.lambda),
                  "WLS smoothness weight (>= 0): larger = smoother map"});
  docs.push_back({"sigma", "number", ParamDefault(d.sigma),
                  "WLS colour sigma (> 0): how strongly image edges stop the smoothing"});
  return docs;
}

std::unique_ptr<StereoMatcher> CreateOpenCvSgbmWls(const MatcherOptions& options,
                                                   MatcherParams& params) {
  return std::make_unique<OpenCvSgbmWls>(options, params);
}

std::unique_ptr<StereoMatcher> CreateOpenCvBlockMatcher(const MatcherOptions& options,
                                                        MatcherParams& params) {
  return std::make_unique<OpenCvBlockMatcher>(options, params);
}

std::unique_ptr<StereoMatcher> CreateOpenCvSgbm(const MatcherOptions& options,
                                                MatcherParams& params) {
  return std::make_unique<OpenCvSgbm>(options, params);
}

}  // namespace linesight
