#include "linesight/ranging/batch.h"

#include <unistd.h>

#include <map>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "linesight/core/atomic_file.h"
#include "linesight/core/error.h"
#include "linesight/io/io_test_util.h"
#include "linesight/io/json_io.h"
#include "linesight/io/pfm.h"

namespace linesight {
namespace {

namespace fs = std::filesystem;
using testing::ExpectInputError;

TEST(BatchManifestTest, ResolvesPathsNamesAndComments) {
  const auto pairs = ParseBatchManifest(
      "# recorded run 3\n"
      "left_0001.png right_0001.png\n"
      "\n"
      "  /data/a/l.png   /data/a/r.png   first  # absolute paths, a name\n"
      "sub/left_0002.png ../r2.png\n",
      "/runs/3/pairs.txt");
  ASSERT_EQ(pairs.size(), 3u);
  EXPECT_EQ(pairs[0].name, "left_0001");
  EXPECT_EQ(pairs[0].left, fs::path("/runs/3/left_0001.png"));
  EXPECT_EQ(pairs[0].left_entry, "left_0001.png");
  EXPECT_EQ(pairs[1].name, "first");
  EXPECT_EQ(pairs[1].right, fs::path("/data/a/r.png"));
  EXPECT_EQ(pairs[2].left, fs::path("/runs/3/sub/left_0002.png"));
  EXPECT_EQ(pairs[2].right, fs::path("/runs/r2.png"));
}

TEST(BatchManifestTest, BadLinesNameTheFileAndLine) {
  ExpectInputError([] { ParseBatchManifest("a.png b.png\nc.png\n", "m.txt"); },
                   {"m.txt:2", "<left> <right> [<name>]", "1 field"});
  ExpectInputError([] { ParseBatchManifest("a.png b.png x\nc.png d.png x\n", "m.txt"); },
                   {"m.txt:2", "'x'", "earlier pair"});
  ExpectInputError([] { ParseBatchManifest("a.png b.png summary\n", "m.txt"); },
                   {"m.txt:1", "'summary'"});
  ExpectInputError([] { ParseBatchManifest("# nothing\n\n", "m.txt"); }, {"m.txt", "no pairs"});
  ExpectInputError([] { ReadBatchManifest("/nonexistent/m.txt"); }, {"/nonexistent/m.txt"});
}

TEST(BatchManifestTest, GlobsPairInSortedOrder) {
  const fs::path dir =
      fs::temp_directory_path() / ("linesight_batch_globs_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  for (const char* f : {"l_2.png", "l_1.png", "r_1.png", "r_2.png", "r_3.png"}) {
    WriteTextAtomic(dir / f, "");
  }
  const auto pairs = BatchPairsFromGlobs((dir / "l_*.png").string(), (dir / "r_[12].png").string());
  ASSERT_EQ(pairs.size(), 2u);
  EXPECT_EQ(pairs[0].name, "l_1");
  EXPECT_EQ(pairs[0].right, dir / "r_1.png");
  EXPECT_EQ(pairs[1].left, dir / "l_2.png");
  ExpectInputError(
      [&] { BatchPairsFromGlobs((dir / "l_*.png").string(), (dir / "r_*.png").string()); },
      {"matches 2 files", "matches 3"});
  fs::remove_all(dir);
}

TEST(BatchShardTest, ParsesShardsAndSlurmArrays) {
  EXPECT_EQ(ParseBatchShard("2/4").index, 2);
  EXPECT_EQ(ParseBatchShard("2/4").count, 4);
  for (const char* bad : {"4/4", "-1/4", "1", "1/0", "a/b", "1/4x", ""}) {
    EXPECT_THROW(ParseBatchShard(bad), UsageError) << bad;
  }
  const BatchShard shard{1, 3};
  EXPECT_TRUE(shard.Owns(1));
  EXPECT_TRUE(shard.Owns(4));
  EXPECT_FALSE(shard.Owns(3));

  std::map<std::string, std::string> env;
  const auto getenv = [&env](const char* name) -> const char* {
    const auto it = env.find(name);
    return it == env.end() ? nullptr : it->second.c_str();
  };
  EXPECT_FALSE(BatchShardFromSlurm(getenv).has_value());  // not an array task
  env = {{"SLURM_ARRAY_TASK_ID", "7"},
         {"SLURM_ARRAY_TASK_COUNT", "4"},
         {"SLURM_ARRAY_TASK_MIN", "5"},
         {"SLURM_ARRAY_TASK_MAX", "8"}};  // --array=5-8
  const auto slurm = BatchShardFromSlurm(getenv);
  ASSERT_TRUE(slurm.has_value());
  EXPECT_EQ(slurm->index, 2);
  EXPECT_EQ(slurm->count, 4);
  env["SLURM_ARRAY_TASK_MAX"] = "11";  // --array=5-11:2 leaves gaps
  ExpectInputError([&] { BatchShardFromSlurm(getenv); }, {"--array=0-3", "--shard"});
}

// A rectified pair of random texture whose right view is the left shifted by `shift` px.
void WriteShiftedPair(const fs::path& left, const fs::path& right, int shift, unsigned seed) {
  cv::Mat texture(64, 96 + shift, CV_8UC1);
  cv::theRNG().state = seed;
  cv::randu(texture, 0, 255);
  cv::GaussianBlur(texture, texture, cv::Size(3, 3), 0.8);
  ASSERT_TRUE(cv::imwrite(left.string(), texture(cv::Rect(0, 0, 96, 64))));
  ASSERT_TRUE(cv::imwrite(right.string(), texture(cv::Rect(shift, 0, 96, 64))));
}

class BatchRunTest : public testing::TempDirTest {
 protected:
  void SetUp() override {
    TempDirTest::SetUp();
    std::string manifest;
    for (int i = 0; i < 5; ++i) {
      WriteShiftedPair(dir_ / fmt::format("l{}.png", i), dir_ / fmt::format("r{}.png", i), 3 + i,
                       100 + i);
      manifest += fmt::format("l{0}.png r{0}.png pair{0}\n", i);
    }
    WriteTextAtomic(dir_ / "pairs.txt", manifest);
    pairs_ = ReadBatchManifest(dir_ / "pairs.txt");
    options_.method = "sgm";
    options_.matcher.num_disparities = 16;
    options_.matcher.threads = 1;
  }
  BatchOptions Options(const std::string& out) const {
    BatchOptions o = options_;
    o.out = dir_ / out;
    return o;
  }
  std::vector<BatchPair> pairs_;
  BatchOptions options_;
};

TEST_F(BatchRunTest, ProcessesEveryPairThenSkipsThemWhenRunAgain) {
  const nlohmann::json first = RunBatch(pairs_, Options("out"));
  EXPECT_EQ(first["done"], 5);
  EXPECT_EQ(first["skipped"], 0);
  EXPECT_EQ(first["failed"], 0);
  for (int i = 0; i < 5; ++i) {
    const cv::Mat d = ReadPfm(dir_ / "out" / fmt::format("pair{}.pfm", i));
    // The matcher's output: the pair's shift at the image's centre.
    EXPECT_NEAR(d.at<float>(32, 60), 3 + i, 0.25) << i;
    const nlohmann::json report = ReadJson(dir_ / "out" / fmt::format("pair{}.json", i));
    EXPECT_EQ(report["left"], fmt::format("l{}.png", i));
    EXPECT_EQ(report["method"], "sgm");
  }
  EXPECT_EQ(ReadJson(dir_ / "out" / "summary.json")["done"], 5);
  const nlohmann::json again = RunBatch(pairs_, Options("out"));
  EXPECT_EQ(again["done"], 0);
  EXPECT_EQ(again["skipped"], 5);
}

TEST_F(BatchRunTest, AFailedPairIsReportedAndTheOthersAreDone) {
  fs::remove(dir_ / "r2.png");
  const nlohmann::json summary = RunBatch(pairs_, Options("out"));
  EXPECT_EQ(summary["done"], 4);
  EXPECT_EQ(summary["failed"], 1);
  const nlohmann::json& failed = summary["pairs"][2];
  EXPECT_EQ(failed["name"], "pair2");
  EXPECT_EQ(failed["status"], "failed");
  EXPECT_NE(failed["error"].get<std::string>().find("r2.png"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir_ / "out" / "pair2.pfm"));
  EXPECT_FALSE(fs::exists(dir_ / "out" / "pair2.json"));
  // Once the input is there, a second run does only the missing pair.
  WriteShiftedPair(dir_ / "l2.png", dir_ / "r2.png", 5, 102);
  const nlohmann::json again = RunBatch(pairs_, Options("out"));
  EXPECT_EQ(again["done"], 1);
  EXPECT_EQ(again["skipped"], 4);
}

TEST_F(BatchRunTest, ShardsMergeIntoTheOneProcessResult) {
  RunBatch(pairs_, Options("single"));
  for (int shard = 0; shard < 3; ++shard) {
    BatchOptions o = Options("sharded");
    o.shard = {shard, 3};
    const nlohmann::json summary = RunBatch(pairs_, o);
    EXPECT_EQ(summary["pairs"].size(), shard < 2 ? 2u : 1u);
    EXPECT_TRUE(fs::exists(dir_ / "sharded" / fmt::format("summary.shard-{}-of-3.json", shard)));
    if (shard == 1) {
      // Merging before every shard has run names the missing shard.
      ExpectInputError([&] { MergeBatchSummaries(pairs_, dir_ / "sharded"); },
                       {"summary.shard-2-of-3.json", "missing"});
    }
  }
  const nlohmann::json merged = MergeBatchSummaries(pairs_, dir_ / "sharded");
  EXPECT_EQ(merged["done"], 5);
  EXPECT_EQ(merged["missing"], 0);
  ASSERT_EQ(merged["pairs"].size(), 5u);
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(merged["pairs"][i]["name"], fmt::format("pair{}", i));
    EXPECT_EQ(merged["pairs"][i]["shard"], i % 3);
    for (const char* ext : {".pfm", ".json"}) {
      const std::string file = fmt::format("pair{}{}", i, ext);
      EXPECT_EQ(ReadTextFile(dir_ / "sharded" / file), ReadTextFile(dir_ / "single" / file))
          << file;
    }
  }
  // A pair whose outputs went away is reported, not counted as done.
  fs::remove(dir_ / "sharded" / "pair4.json");
  EXPECT_EQ(MergeBatchSummaries(pairs_, dir_ / "sharded")["missing"], 1);
}

TEST_F(BatchRunTest, BadSettingsFailBeforeAnyPair) {
  BatchOptions o = Options("out");
  o.method = "nosuchmatcher";
  EXPECT_THROW(RunBatch(pairs_, o), UsageError);
  EXPECT_FALSE(fs::exists(dir_ / "out" / "pair0.pfm"));
}

}  // namespace
}  // namespace linesight
