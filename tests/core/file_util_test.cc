#include "quadhand/core/file_util.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>

namespace quadhand::core {
namespace {

namespace fs = std::filesystem;

class FileUtilTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("quadhand_file_util_" + std::to_string(getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(FileUtilTest, AtomicWriteLeavesOnlyTheFinalFile) {
  const std::string path = (dir_ / "out.txt").string();
  ASSERT_TRUE(WriteFileAtomically(path, "hello").ok());
  auto read = ReadFileToString(path);
  ASSERT_TRUE(read.ok());
  EXPECT_EQ(*read, "hello");
  int entries = 0;
  for (const auto& entry : fs::directory_iterator(dir_)) entries += entry.is_regular_file();
  EXPECT_EQ(entries, 1);
}

TEST_F(FileUtilTest, UncommittedSetLeavesNothingBehind) {
  {
    AtomicFileSet set;
    ASSERT_TRUE(set.Stage((dir_ / "a").string(), "a").ok());
    ASSERT_TRUE(set.Stage((dir_ / "b").string(), "b").ok());
  }
  EXPECT_TRUE(fs::is_empty(dir_));
}

TEST_F(FileUtilTest, WriteIntoMissingDirectoryFailsCleanly) {
  const Status s = WriteFileAtomically((dir_ / "missing" / "x").string(), "x");
  EXPECT_EQ(s.code(), StatusCode::kIoError);
  EXPECT_NE(s.message().find("missing"), std::string::npos);
}

TEST_F(FileUtilTest, ReadMissingFileIsNotFound) {
  EXPECT_EQ(ReadFileToString((dir_ / "nope").string()).status().code(), StatusCode::kNotFound);
}

TEST(PathTest, ResolvesRelativeToTheBaseDirectory) {
  EXPECT_EQ(DirectoryOf("a/b/c.yaml"), "a/b");
  EXPECT_EQ(DirectoryOf("c.yaml"), ".");
  EXPECT_EQ(DirectoryOf("/c.yaml"), "/");
  EXPECT_EQ(ResolvePath("a/b", "../x.pcd"), "a/b/../x.pcd");
  EXPECT_EQ(ResolvePath("a/b", "/abs.pcd"), "/abs.pcd");
  EXPECT_EQ(ResolvePath(".", "x.pcd"), "x.pcd");
}

}  // namespace
}  // namespace quadhand::core
