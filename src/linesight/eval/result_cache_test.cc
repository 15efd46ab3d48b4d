#include "linesight/eval/result_cache.h"

#include <fstream>

#include <gtest/gtest.h>

#include "linesight/core/atomic_file.h"
#include "linesight/core/error.h"
#include "linesight/eval/dataset.h"
#include "linesight/eval/report.h"
#include "linesight/eval/synthetic_scenes_test_util.h"

namespace linesight {
namespace {

namespace fs = std::filesystem;

class ResultCacheTest : public ::testing::Test {
 protected:
  void SetUp() override {
    testing::WriteTwoSyntheticScenes(dir_.path() / "data");
    scenes_ = FindScenes(dir_.path() / "data");
    ASSERT_EQ(scenes_.size(), 2u);
  }
  EvalStereoOptions Options(const ResultCache* cache) const {
    EvalStereoOptions o;
    o.methods = {"sgbm", "bm"};
    o.noise = {NoiseSpec(), NoiseSpec::Parse("gauss:0.1")};
    o.threads = 1;
    o.cache = cache;
    return o;
  }
  static size_t Cached(const EvalStereoReport& report) {
    size_t n = 0;
    for (const auto& r : report.results) n += r.from_cache;
    return n;
  }
  // `same_run`: b's results are a's, read back from the cache (so the times match too).
  static void ExpectSameMetrics(const EvalStereoReport& a, const EvalStereoReport& b,
                                bool same_run) {
    ASSERT_EQ(a.results.size(), b.results.size());
    for (size_t i = 0; i < a.results.size(); ++i) {
      const auto& x = a.results[i];
      const auto& y = b.results[i];
      EXPECT_EQ(x.set + x.scene + x.method + x.noise, y.set + y.scene + y.method + y.noise);
      if (same_run) {
        EXPECT_EQ(x.ms, y.ms);
      }
      EXPECT_EQ(x.settings, y.settings);
      ASSERT_EQ(x.regions.size(), y.regions.size());
      for (const auto& [region, m] : x.regions) {
        EXPECT_EQ(m.ToJson(), y.regions.at(region).ToJson()) << region;  // bit-exact doubles
      }
    }
  }
  size_t EntryCount() const {
    size_t n = 0;
    for (const auto& e : fs::recursive_directory_iterator(cache_dir())) {
      n += e.is_regular_file() && e.path().extension() == ".json";
    }
    return n;
  }
  fs::path cache_dir() const { return dir_.path() / "cache"; }

  testing::ScopedTempDir dir_;
  std::vector<SceneRef> scenes_;
};

TEST_F(ResultCacheTest, HitReproducesTheMetricsAndNamesTheRunThatMeasuredThem) {
  const ResultCache cache(cache_dir(), "abc123 (2026-12-01 22:00 UTC)", "test machine");
  const EvalStereoReport first = RunEvalStereo(scenes_, Options(&cache));
  EXPECT_EQ(Cached(first), 0u);
  EXPECT_EQ(EntryCount(), 2u * 2u * 2u);  // scenes x noise x methods
  const EvalStereoReport second = RunEvalStereo(scenes_, Options(&cache));
  EXPECT_EQ(Cached(second), second.results.size());
  ExpectSameMetrics(first, second, true);
  EXPECT_EQ(second.results[0].measured_commit, "abc123 (2026-12-01 22:00 UTC)");
  EXPECT_EQ(second.results[0].measured_machine, "test machine");
  EXPECT_FALSE(second.results[0].measured_date.empty());
  // Without a cache the same run reproduces the metrics (the cache stores, it does not invent).
  ExpectSameMetrics(first, RunEvalStereo(scenes_, Options(nullptr)), false);
}

TEST_F(ResultCacheTest, SettingsNoiseSeedAndMethodChangesMiss) {
  const ResultCache cache(cache_dir(), "c", "m");
  RunEvalStereo(scenes_, Options(&cache));
  EvalStereoOptions other_settings = Options(&cache);
  other_settings.params = {{"sgbm.block", "7"}};
  const auto r1 = RunEvalStereo(scenes_, other_settings);
  for (const auto& r : r1.results) EXPECT_EQ(r.from_cache, r.method == "bm") << r.method;

  EvalStereoOptions other_seed = Options(&cache);
  other_seed.noise_seed = 2;
  for (const auto& r : RunEvalStereo(scenes_, other_seed).results) {
    EXPECT_EQ(r.from_cache, r.noise == "clean") << r.noise;  // clean input does not use the seed
  }

  EvalStereoOptions other_noise = Options(&cache);
  other_noise.noise = {NoiseSpec::Parse("gauss:0.2")};
  EXPECT_EQ(Cached(RunEvalStereo(scenes_, other_noise)), 0u);

  EvalStereoOptions write_only = Options(&cache);
  write_only.cache_read_methods = {"bm"};
  for (const auto& r : RunEvalStereo(scenes_, write_only).results) {
    EXPECT_EQ(r.from_cache, r.method == "bm");
  }
}

TEST_F(ResultCacheTest, ChangedImageOrGroundTruthFileMisses) {
  const ResultCache cache(cache_dir(), "c", "m");
  EvalStereoOptions o = Options(&cache);
  o.noise = {NoiseSpec()};
  RunEvalStereo(scenes_, o);
  EXPECT_EQ(Cached(RunEvalStereo(scenes_, o)), 4u);
  // One pixel of alpha's left image changes: alpha misses, beta still hits.
  const fs::path alpha = dir_.path() / "data" / "middlebury-2001-2003" / "alpha";
  cv::Mat left = cv::imread((alpha / "imL.png").string(), cv::IMREAD_COLOR);
  left.at<cv::Vec3b>(3, 7)[1] ^= 1;
  cv::imwrite((alpha / "imL.png").string(), left);
  for (const auto& r : RunEvalStereo(scenes_, o).results) {
    EXPECT_EQ(r.from_cache, r.scene == "beta") << r.scene;
  }
  // Beta's ground truth changes: beta misses too (alpha now hits its new entry).
  const fs::path beta = dir_.path() / "data" / "middlebury-2001-2003" / "beta";
  cv::Mat gt = cv::imread((beta / "groundtruth.png").string(), cv::IMREAD_GRAYSCALE);
  gt.at<uchar>(10, 100) = 0;
  cv::imwrite((beta / "groundtruth.png").string(), gt);
  for (const auto& r : RunEvalStereo(scenes_, o).results) {
    EXPECT_EQ(r.from_cache, r.scene == "alpha") << r.scene;
  }
}

TEST_F(ResultCacheTest, CorruptOrForeignEntryIsIgnoredAndRewritten) {
  const ResultCache cache(cache_dir(), "c", "m");
  EvalStereoOptions o = Options(&cache);
  o.methods = {"bm"};
  o.noise = {NoiseSpec()};
  const EvalStereoReport fresh = RunEvalStereo(scenes_, o);
  std::vector<fs::path> entries;
  for (const auto& e : fs::recursive_directory_iterator(cache_dir())) {
    if (e.is_regular_file()) entries.push_back(e.path());
  }
  ASSERT_EQ(entries.size(), 2u);
  WriteTextAtomic(entries[0], "{ not json");  // truncated / garbage
  nlohmann::json foreign = nlohmann::json::parse(ReadTextFile(entries[1]));
  foreign["key"]["settings"]["block_size"] = 99;  // a key that does not belong here
  WriteTextAtomic(entries[1], foreign.dump());
  ::testing::internal::CaptureStderr();
  const EvalStereoReport rerun = RunEvalStereo(scenes_, o);
  const std::string warnings = ::testing::internal::GetCapturedStderr();
  EXPECT_EQ(Cached(rerun), 0u);
  EXPECT_NE(warnings.find(entries[0].string()), std::string::npos) << warnings;
  EXPECT_NE(warnings.find(entries[1].string()), std::string::npos) << warnings;
  ExpectSameMetrics(fresh, rerun, false);
  // Both entries were rewritten and hit again.
  EXPECT_EQ(Cached(RunEvalStereo(scenes_, o)), 2u);
  // A cell whose "result" lacks a field is a miss too, not a crash.
  nlohmann::json partial = nlohmann::json::parse(ReadTextFile(entries[0]));
  partial["result"].erase("regions");
  WriteTextAtomic(entries[0], partial.dump());
  EXPECT_EQ(Cached(RunEvalStereo(scenes_, o)), 1u);
}

TEST_F(ResultCacheTest, CacheOnlyMethodsListMissingCellsInsteadOfRunning) {
  const ResultCache cache(cache_dir(), "c", "m");
  EvalStereoOptions o = Options(&cache);
  o.methods = {"bm"};
  o.noise = {NoiseSpec()};
  RunEvalStereo({scenes_[0]}, o);  // alpha only
  o.cache_only_methods = {"bm"};
  const EvalStereoReport report = RunEvalStereo(scenes_, o);
  ASSERT_EQ(report.results.size(), 1u);
  EXPECT_TRUE(report.results[0].from_cache);
  ASSERT_EQ(report.missing.size(), 1u);
  EXPECT_EQ(report.missing[0], "middlebury-2001-2003/beta/clean/bm");
  EvalStereoOptions no_cache = o;
  no_cache.cache = nullptr;
  EXPECT_THROW(RunEvalStereo(scenes_, no_cache), OptionError);
}

TEST_F(ResultCacheTest, ReportTakesGcFromTheCacheAndListsWhatIsMissing) {
  ReportOptions options;
  options.data_dir = dir_.path() / "data";
  options.out_dir = dir_.path() / "results";
  options.methods = {"isgm", "gc"};
  options.noise = {NoiseSpec(), NoiseSpec::Parse("sp:0.15")};
  options.sweep_methods.clear();
  options.obstacles = false;
  options.threads = 1;
  options.gc_jobs = 1;
  options.show_progress = false;
  options.cache_dir = cache_dir();
  options.commit = "first-commit";
  // Fill gc's cells of alpha only, the way a background run does.
  {
    const ResultCache cache(cache_dir(), "fill-commit", "fill machine");
    EvalStereoOptions fill;
    fill.methods = {"gc"};
    fill.threads = 1;
    fill.noise = options.noise;
    fill.cache = &cache;
    RunEvalStereo({scenes_[0]}, fill);
  }
  options.gc_cached_only = true;
  const std::string page = GenerateReport(options);
  EXPECT_NE(page.find("## 7. Rows from the result cache"), std::string::npos);
  EXPECT_NE(page.find("| middlebury-2001-2003 | alpha | clean | gc |"), std::string::npos) << page;
  EXPECT_NE(page.find("| middlebury-2001-2003 | alpha | sp:0.15 | gc |"), std::string::npos);
  EXPECT_NE(page.find("fill-commit"), std::string::npos);
  EXPECT_NE(page.find("- `middlebury-2001-2003/beta (gc)`: clean, sp:0.15\n"), std::string::npos)
      << page;
  EXPECT_NE(page.find("2 gc cell(s) are missing"), std::string::npos);
  EXPECT_NE(page.find("gc at sp:0.15: 1 of 2 scenes"), std::string::npos);
  // isgm is not read from the cache by default: it is measured again.
  EXPECT_EQ(page.find("| alpha | clean | isgm |"), std::string::npos);
  ReportOptions without_cache = options;
  without_cache.cache_dir.clear();
  EXPECT_THROW(without_cache.Check(), OptionError);
}

}  // namespace
}  // namespace linesight
