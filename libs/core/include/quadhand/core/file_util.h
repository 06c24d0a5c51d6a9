// File helpers: atomic writes (temporary name + rename, so no CLI leaves a
// partial output behind) and whole-file reads.
#pragma once

#include <string>
#include <vector>

#include "quadhand/core/status.h"

namespace quadhand::core {

// Reads a whole file into memory.
Result<std::string> ReadFileToString(const std::string& path);

// Writes `contents` to `path` atomically: to "<path>.tmp-<pid>" first, then
// renamed. On failure nothing is left at `path` or at the temporary name.
Status WriteFileAtomically(const std::string& path, const std::string& contents);

// Several outputs that appear together or not at all: Stage() writes each
// under a temporary name, Commit() renames them all, and the destructor
// removes whatever was staged but not committed.
class AtomicFileSet {
 public:
  AtomicFileSet() = default;
  AtomicFileSet(const AtomicFileSet&) = delete;
  AtomicFileSet& operator=(const AtomicFileSet&) = delete;
  ~AtomicFileSet();

  Status Stage(const std::string& path, const std::string& contents);
  Status Commit();

 private:
  std::vector<std::pair<std::string, std::string>> staged_;  // (temporary, final)
};

// Directory of `path` ("." if none), and `relative` resolved against `base_dir`
// unless it is absolute.
std::string DirectoryOf(const std::string& path);
std::string ResolvePath(const std::string& base_dir, const std::string& relative);

}  // namespace quadhand::core
