// File helpers: atomic writes (temporary name + rename, so no CLI leaves a
// partial output behind) and whole-file reads.
#pragma once

#include <cstddef>
#include <iosfwd>
#include <cstdio>
#include <string>
#include <string_view>
#include <vector>

#include "quadhand/core/status.h"

namespace quadhand::core {

// Largest file ReadFileToString reads by default (tasks, configurations,
// URDF, SRDF, SDF grids): far beyond any real one, far below the memory.
inline constexpr unsigned long long kMaxReadBytes = 1ull << 30;

// Reads a whole regular file into memory: NotFound if it is missing,
// InvalidArgument for a directory, device or FIFO (checked before opening,
// so a FIFO cannot block and /dev/zero cannot fill the memory) or a file
// larger than `max_bytes`, each naming the path.
Result<std::string> ReadFileToString(const std::string& path, unsigned long long max_bytes = kMaxReadBytes);

// A regular file mapped read-only (and read ahead at once) for as long as
// this lives: large inputs (link SDFs, CAD meshes) are hashed and copied
// straight from the page cache, without a buffer of the file's size to
// allocate and fill. Not mapped (mapped() false) for anything else: a
// missing, empty or non-regular file, one larger than `max_bytes` (a huge
// sparse file must not be read in), or no mapping; read it with
// ReadFileToString then, for its error messages. Files are replaced by
// renaming, never truncated in place, so a mapping stays valid.
class MappedFile {
 public:
  explicit MappedFile(const std::string& path, unsigned long long max_bytes = kMaxReadBytes);
  ~MappedFile();
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;
  bool mapped() const { return data_ != nullptr; }
  std::string_view bytes() const { return {static_cast<const char*>(data_), size_}; }

 private:
  void* data_ = nullptr;
  std::size_t size_ = 0;
};

// std::getline with a limit: a file without line breaks (a disk image, a
// sparse file of zeros) must not be read whole into one line. kLine with the
// line (without its line break) in *line; kEnd at the end of the input;
// kTooLong when the line holds more than `max_length` characters (the
// stream is then left inside it).
enum class LineRead { kLine, kEnd, kTooLong };
LineRead ReadBoundedLine(std::istream& in, std::size_t max_length, std::string* line);

// Writes `contents` to `path` atomically: to "<path>.tmp-<pid>" first, then
// renamed. On failure nothing is left at `path` or at the temporary name.
Status WriteFileAtomically(const std::string& path, const std::string& contents);

// Whether `path` may be written as an output: not empty, and not an
// existing directory, device, FIFO, socket or symbolic link (a rename would
// replace the link or the device itself). InvalidArgument naming the path.
Status CheckOutputPath(const std::string& path);
// CheckOutputPath, and that a file can be made in its folder (it exists and
// accepts a new file): what a program checks before any work, so that an
// output that cannot be written fails at once, in one line naming it.
Status CheckOutputPathAndFolder(const std::string& path);

// Whether the folder `dir` exists or can be made: made (with any missing
// parents) and removed again, so that a program can fail at once on a bad
// output folder yet make it only when its outputs are ready.
Status CheckFolderCanBeMade(const std::string& dir);

// Whether two paths name the same file (the same existing file, or the same
// normalised absolute path).
bool SameFile(const std::string& a, const std::string& b);

// Several outputs that appear together or not at all: Stage() writes each
// under a temporary name, Commit() renames them all, and the destructor
// removes whatever was staged but not committed; so does a SIGINT, SIGTERM
// or SIGHUP that kills a program which keeps their default action. Stage()
// refuses a path that CheckOutputPath() refuses, one staged already (two
// outputs given the same path) and one that names a protected input.
class AtomicFileSet {
 public:
  AtomicFileSet() = default;
  AtomicFileSet(const AtomicFileSet&) = delete;
  AtomicFileSet& operator=(const AtomicFileSet&) = delete;
  ~AtomicFileSet();

  // A file the run reads (task, scene, robot, configuration): never an output.
  void Protect(const std::string& input) { protected_.push_back(input); }
  Status Stage(const std::string& path, const std::string& contents);
  Status Commit();

 private:
  std::vector<std::pair<std::string, std::string>> staged_;  // (temporary, final)
  std::vector<std::string> protected_;
  std::vector<int> slots_;  // the temporaries' entries in the signal cleanup table
};

// A record that grows while a program runs (a flight log): PATH.partial is
// created at the first Append(), each Append() writes and flushes, Finish()
// closes it and renames it to PATH. A program killed in between leaves
// PATH.partial, whose name says that it is incomplete, holding everything
// appended so far. The first error is kept and returned by Finish() (naming
// the file); later appends do nothing.
class GrowingFile {
 public:
  explicit GrowingFile(std::string path);
  GrowingFile(const GrowingFile&) = delete;
  GrowingFile& operator=(const GrowingFile&) = delete;
  ~GrowingFile();

  void Append(const std::string& text);
  Status Finish();
  const std::string& path() const { return path_; }
  std::string partial_path() const { return path_ + ".partial"; }

 private:
  std::string path_;
  std::FILE* file_ = nullptr;
  std::string error_;
};

// Directory of `path` ("." if none), and `relative` resolved against `base_dir`
// unless it is absolute.
std::string DirectoryOf(const std::string& path);
std::string ResolvePath(const std::string& base_dir, const std::string& relative);

// A bundled data file that a program uses by default (e.g.
// "data/bench/window_cup.yaml"): relative to the working directory when it is
// there (the repository root), else in the installed tree beside the program
// (<bin>/../share/quadhand/), else in the source tree the program was built
// from; `relative` itself when none has it (the caller's error names it).
std::string FindBundledFile(const std::string& relative, const std::string& source_dir);

}  // namespace quadhand::core
