#include "linesight/core/atomic_file.h"

#include <gtest/gtest.h>

#include "linesight/core/error.h"

namespace linesight {
namespace {
namespace fs = std::filesystem;

class AtomicFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ =
        fs::temp_directory_path() /
        ("linesight_atomic_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
         ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  size_t FileCount() const {
    return static_cast<size_t>(
        std::distance(fs::directory_iterator(dir_), fs::directory_iterator()));
  }
  fs::path dir_;
};

TEST_F(AtomicFileTest, WritesAndReadsBack) {
  WriteTextAtomic(dir_ / "a.txt", "hello");
  EXPECT_EQ(ReadTextFile(dir_ / "a.txt"), "hello");
  EXPECT_EQ(FileCount(), 1u);
}

TEST_F(AtomicFileTest, FailingWriterLeavesNothingAndKeepsOldFile) {
  WriteTextAtomic(dir_ / "a.txt", "old");
  EXPECT_THROW(WriteFileAtomic(dir_ / "a.txt",
                               [](const fs::path& tmp) {
                                 WriteTextAtomic(tmp, "partial");
                                 throw InputError("boom");
                               }),
               InputError);
  EXPECT_EQ(ReadTextFile(dir_ / "a.txt"), "old");
  EXPECT_EQ(FileCount(), 1u);
}

TEST_F(AtomicFileTest, MissingFolderIsInputError) {
  EXPECT_THROW(WriteTextAtomic(dir_ / "nope" / "a.txt", "x"), InputError);
}

TEST_F(AtomicFileTest, MissingFileNamesPath) {
  try {
    ReadTextFile(dir_ / "missing.txt");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("missing.txt: cannot open: no such file"),
              std::string::npos);
  }
}

TEST_F(AtomicFileTest, TempKeepsExtension) {
  fs::path seen;
  WriteFileAtomic(dir_ / "img.png", [&](const fs::path& tmp) {
    seen = tmp;
    WriteTextAtomic(tmp, "x");
  });
  EXPECT_EQ(seen.extension(), ".png");
  EXPECT_EQ(seen.parent_path(), dir_);
}

}  // namespace
}  // namespace linesight
