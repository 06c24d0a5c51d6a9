#include "quadhand/core/file_util.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

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

TEST_F(FileUtilTest, AGrowingFileIsPartialUntilFinished) {
  const std::string path = (dir_ / "log.csv").string();
  {
    GrowingFile file(path);
    file.Append("a\n");
    // Readable as written so far, under a name that says it is incomplete.
    EXPECT_EQ(*ReadFileToString(path + ".partial"), "a\n");
    EXPECT_FALSE(fs::exists(path));
    file.Append("b\n");
    ASSERT_TRUE(file.Finish().ok());
  }
  EXPECT_EQ(*ReadFileToString(path), "a\nb\n");
  EXPECT_FALSE(fs::exists(path + ".partial"));
  // Abandoned (the program killed): the partial file stays as it was.
  {
    GrowingFile file((dir_ / "killed.csv").string());
    file.Append("x\n");
  }
  EXPECT_EQ(*ReadFileToString((dir_ / "killed.csv.partial").string()), "x\n");
  EXPECT_FALSE(fs::exists(dir_ / "killed.csv"));
  // A folder that does not exist: the error names the file.
  GrowingFile nowhere((dir_ / "missing" / "log.csv").string());
  nowhere.Append("y\n");
  const Status s = nowhere.Finish();
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("log.csv.partial"), std::string::npos) << s.message();
}

TEST_F(FileUtilTest, AnOutputsFolderMustAcceptANewFile) {
  EXPECT_TRUE(CheckOutputPathAndFolder((dir_ / "out.csv").string()).ok());
  int entries = 0;
  for (const auto& entry : fs::directory_iterator(dir_)) entries += entry.is_regular_file();
  EXPECT_EQ(entries, 0);  // the probe is gone
  const Status missing = CheckOutputPathAndFolder((dir_ / "missing" / "out.csv").string());
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.message().find("does not exist"), std::string::npos) << missing.message();
  EXPECT_FALSE(CheckOutputPathAndFolder("/proc/out.csv").ok());
  EXPECT_FALSE(CheckOutputPathAndFolder(dir_.string()).ok());  // a directory, as CheckOutputPath says
}

TEST_F(FileUtilTest, UncommittedSetLeavesNothingBehind) {
  {
    AtomicFileSet set;
    ASSERT_TRUE(set.Stage((dir_ / "a").string(), "a").ok());
    ASSERT_TRUE(set.Stage((dir_ / "b").string(), "b").ok());
  }
  EXPECT_TRUE(fs::is_empty(dir_));
}

// Stage() refuses what a rename would destroy or what aliases another
// output or an input; the refused set leaves nothing behind, and the input
// is untouched.
TEST_F(FileUtilTest, StageRefusesDestructiveAndAliasedOutputs) {
  const std::string input = (dir_ / "task.yaml").string();
  ASSERT_TRUE(WriteFileAtomically(input, "keep me").ok());
  fs::create_directories(dir_ / "folder");
  fs::create_symlink(dir_ / "target", dir_ / "link");
  EXPECT_FALSE(CheckOutputPath("").ok());
  EXPECT_FALSE(CheckOutputPath((dir_ / "folder").string()).ok());
  EXPECT_FALSE(CheckOutputPath((dir_ / "link").string()).ok());
  EXPECT_FALSE(CheckOutputPath("/dev/null").ok());
  EXPECT_TRUE(CheckOutputPath((dir_ / "new.csv").string()).ok());
  EXPECT_TRUE(CheckOutputPath(input).ok());  // a regular file may be replaced, unless protected
  EXPECT_TRUE(SameFile(input, (dir_ / "." / "task.yaml").string()));
  EXPECT_TRUE(SameFile((dir_ / "a.csv").string(), (dir_ / "folder" / ".." / "a.csv").string()));
  EXPECT_FALSE(SameFile(input, (dir_ / "a.csv").string()));
  {
    AtomicFileSet set;
    set.Protect(input);
    ASSERT_TRUE(set.Stage((dir_ / "a.csv").string(), "a").ok());
    const Status aliased = set.Stage((dir_ / "folder" / ".." / "a.csv").string(), "b");
    EXPECT_FALSE(aliased.ok());
    EXPECT_NE(aliased.message().find("two outputs"), std::string::npos) << aliased.message();
    const Status overwrite = set.Stage((dir_ / "." / "task.yaml").string(), "c");
    EXPECT_FALSE(overwrite.ok());
    EXPECT_NE(overwrite.message().find("input"), std::string::npos) << overwrite.message();
  }
  EXPECT_FALSE(fs::exists(dir_ / "a.csv"));
  EXPECT_EQ(*ReadFileToString(input), "keep me");
}

// Only regular files are read, within a size: a FIFO would block, a device
// like /dev/zero would fill the memory.
TEST_F(FileUtilTest, ReadsOnlyRegularFilesWithinTheLimit) {
  const std::string fifo = (dir_ / "fifo").string();
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  for (const std::string& path : {fifo, std::string("/dev/zero"), dir_.string()}) {
    auto read = ReadFileToString(path);
    ASSERT_FALSE(read.ok()) << path;
    EXPECT_EQ(read.status().code(), StatusCode::kInvalidArgument) << path;
    EXPECT_NE(read.status().message().find(path), std::string::npos) << read.status().message();
  }
  const std::string big = (dir_ / "big.txt").string();
  ASSERT_TRUE(WriteFileAtomically(big, std::string(100, 'x')).ok());
  EXPECT_TRUE(ReadFileToString(big, 100).ok());
  auto too_big = ReadFileToString(big, 99);
  ASSERT_FALSE(too_big.ok());
  EXPECT_NE(too_big.status().message().find("100 bytes"), std::string::npos) << too_big.status().message();
}

// A program killed between staging and committing leaves no temporary file.
TEST_F(FileUtilTest, AKilledProgramLeavesNoTemporaryFile) {
  const std::string path = (dir_ / "report.json").string();
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    AtomicFileSet set;
    if (!set.Stage(path, "partial").ok()) _exit(3);
    raise(SIGTERM);
    _exit(4);  // not reached: SIGTERM's default action ends the process
  }
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFSIGNALED(status)) << "exit status " << WEXITSTATUS(status);
  EXPECT_EQ(WTERMSIG(status), SIGTERM);
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

// Lines of any length up to the limit, across the reader's internal chunks
// and with or without a final line break; a longer one stops the reading
// after the limit instead of taking the rest of the file.
TEST(ReadBoundedLineTest, ReadsLinesUpToTheLimitAndStopsAtALongerOne) {
  const std::string long_line(10000, 'x');
  std::istringstream in("a\n\n" + long_line + "\n" + std::string(4095, 'y') + "\nlast");
  std::string line;
  ASSERT_EQ(ReadBoundedLine(in, 20000, &line), LineRead::kLine);
  EXPECT_EQ(line, "a");
  ASSERT_EQ(ReadBoundedLine(in, 20000, &line), LineRead::kLine);
  EXPECT_EQ(line, "");
  ASSERT_EQ(ReadBoundedLine(in, 20000, &line), LineRead::kLine);
  EXPECT_EQ(line, long_line);
  ASSERT_EQ(ReadBoundedLine(in, 20000, &line), LineRead::kLine);
  EXPECT_EQ(line, std::string(4095, 'y'));
  ASSERT_EQ(ReadBoundedLine(in, 20000, &line), LineRead::kLine);
  EXPECT_EQ(line, "last");
  EXPECT_EQ(ReadBoundedLine(in, 20000, &line), LineRead::kEnd);
  EXPECT_EQ(ReadBoundedLine(in, 20000, &line), LineRead::kEnd);

  std::istringstream exact(std::string(8190, 'z'));  // two full chunks, then the end
  ASSERT_EQ(ReadBoundedLine(exact, 8190, &line), LineRead::kLine);
  EXPECT_EQ(line.size(), 8190u);
  EXPECT_EQ(ReadBoundedLine(exact, 8190, &line), LineRead::kEnd);

  std::string zeros(1 << 20, '\0');  // no line break at all
  std::istringstream binary(zeros);
  EXPECT_EQ(ReadBoundedLine(binary, 65536, &line), LineRead::kTooLong);
  EXPECT_TRUE(line.empty());
  EXPECT_LE(binary.tellg(), 65536 + 8192) << "read no further than the limit and a chunk";
  std::istringstream with_nul(std::string("a\0b\nc", 5));
  ASSERT_EQ(ReadBoundedLine(with_nul, 10, &line), LineRead::kLine);
  EXPECT_EQ(line, std::string("a\0b", 3));
}

TEST(PathTest, ResolvesRelativeToTheBaseDirectory) {
  EXPECT_EQ(DirectoryOf("a/b/c.yaml"), "a/b");
  EXPECT_EQ(DirectoryOf("c.yaml"), ".");
  EXPECT_EQ(DirectoryOf("/c.yaml"), "/");
  EXPECT_EQ(ResolvePath("a/b", "../x.pcd"), "a/b/../x.pcd");
  EXPECT_EQ(ResolvePath("a/b", "/abs.pcd"), "/abs.pcd");
  EXPECT_EQ(ResolvePath(".", "x.pcd"), "x.pcd");
}

// A program's default data file is found from any working directory: in it
// first, then in the installed tree beside the program, then in the source
// tree; otherwise the name is returned as given, for the error to name.
TEST_F(FileUtilTest, FindsABundledFileFromAnyWorkingDirectory) {
  const fs::path source = dir_ / "source";
  fs::create_directories(source / "data" / "bench");
  std::ofstream(source / "data" / "bench" / "config.yaml") << "task: t.yaml\n";
  const fs::path previous = fs::current_path();
  fs::create_directories(dir_ / "elsewhere");
  fs::current_path(dir_ / "elsewhere");
  EXPECT_EQ(FindBundledFile("data/bench/config.yaml", source.string()),
            (source / "data" / "bench" / "config.yaml").string());
  EXPECT_EQ(FindBundledFile("data/bench/missing.yaml", source.string()), "data/bench/missing.yaml");
  EXPECT_EQ(FindBundledFile("data/bench/config.yaml", ""), "data/bench/config.yaml");
  // The working directory wins (a repository checkout's own data).
  fs::create_directories(dir_ / "elsewhere" / "data" / "bench");
  std::ofstream(dir_ / "elsewhere" / "data" / "bench" / "config.yaml") << "task: u.yaml\n";
  EXPECT_EQ(FindBundledFile("data/bench/config.yaml", source.string()), "data/bench/config.yaml");
  fs::current_path(previous);
}

}  // namespace
}  // namespace quadhand::core
