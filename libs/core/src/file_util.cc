#include "quadhand/core/file_util.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <istream>
#include <sstream>
#include <system_error>
#include <utility>

namespace quadhand::core {
namespace {

// Staged temporaries, for removal when the process is killed between
// staging and committing (SIGINT, SIGTERM, SIGHUP). The handler may only
// call async-signal-safe functions: it unlinks the registered names and
// re-raises the signal with its default action. It is installed only where
// the program keeps the default action (programs that stop gracefully on
// these signals have their own handler and commit or clean up themselves).
constexpr int kTemporarySlots = 64;
std::atomic<const char*> g_temporaries[kTemporarySlots];

void RemoveTemporariesAndDie(int signal_number) {
  for (std::atomic<const char*>& slot : g_temporaries) {
    if (const char* name = slot.load()) unlink(name);
  }
  ::signal(signal_number, SIG_DFL);
  ::raise(signal_number);
}

void InstallCleanupOnSignals() {
  static const bool installed = [] {
    for (int signal_number : {SIGINT, SIGTERM, SIGHUP}) {
      struct sigaction current {};
      if (sigaction(signal_number, nullptr, &current) != 0 || current.sa_handler != SIG_DFL) continue;
      struct sigaction action {};
      action.sa_handler = RemoveTemporariesAndDie;
      sigemptyset(&action.sa_mask);
      sigaction(signal_number, &action, nullptr);
    }
    return true;
  }();
  (void)installed;
}

// The slot holding `name` (a copy owned by the slot), or -1 when all are in use.
int RegisterTemporary(const std::string& name) {
  InstallCleanupOnSignals();
  char* copy = new char[name.size() + 1];
  std::memcpy(copy, name.c_str(), name.size() + 1);
  for (int i = 0; i < kTemporarySlots; ++i) {
    const char* expected = nullptr;
    if (g_temporaries[i].compare_exchange_strong(expected, copy)) return i;
  }
  delete[] copy;
  return -1;
}

void UnregisterTemporary(int slot) {
  if (slot < 0) return;
  delete[] g_temporaries[slot].exchange(nullptr);
}

std::string TemporaryNameFor(const std::string& path) {
  return path + ".tmp-" + std::to_string(static_cast<long>(getpid()));
}

Status WriteWholeFile(const std::string& path, const std::string& contents) {
  std::FILE* file = std::fopen(path.c_str(), "wb");
  if (file == nullptr) return Status::IoError(path + ": cannot write: " + std::strerror(errno));
  const bool written = std::fwrite(contents.data(), 1, contents.size(), file) == contents.size();
  const bool flushed = std::fflush(file) == 0;
  const bool closed = std::fclose(file) == 0;
  if (!(written && flushed && closed)) {
    std::remove(path.c_str());
    return Status::IoError(path + ": write failed: " + std::strerror(errno));
  }
  return Status::Ok();
}

}  // namespace

LineRead ReadBoundedLine(std::istream& in, std::size_t max_length, std::string* line) {
  line->clear();
  char chunk[4096];
  while (true) {
    in.getline(chunk, sizeof(chunk));
    const std::size_t got = static_cast<std::size_t>(in.gcount());
    const bool chunk_full = in.fail() && !in.eof() && !in.bad() && got == sizeof(chunk) - 1;
    const bool ended_by_break = !in.fail() && !in.eof();
    line->append(chunk, ended_by_break ? got - 1 : got);
    if (line->size() > max_length) {
      line->clear();
      return LineRead::kTooLong;
    }
    if (chunk_full) {
      in.clear();  // getline sets failbit for a chunk without a line break
      continue;
    }
    if (ended_by_break || got > 0 || !line->empty()) return LineRead::kLine;
    return LineRead::kEnd;
  }
}

Result<std::string> ReadFileToString(const std::string& path, unsigned long long max_bytes) {
  namespace fs = std::filesystem;
  std::error_code error;
  const fs::file_status status = fs::status(path, error);
  if (error || !fs::exists(status)) {
    return Status(StatusCode::kNotFound, path + ": cannot open: " +
                                             (error ? error.message() : std::string("no such file or directory")));
  }
  if (fs::is_directory(status)) return Status::InvalidArgument(path + ": is a directory, not a file");
  if (!fs::is_regular_file(status)) {
    return Status::InvalidArgument(path + ": is not a regular file (a device, FIFO or socket)");
  }
  const auto size = fs::file_size(path, error);
  if (!error && size > max_bytes) {
    return Status::InvalidArgument(path + ": " + std::to_string(size) + " bytes, more than the " +
                                   std::to_string(max_bytes) + " this file may have");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    return Status(errno == ENOENT ? StatusCode::kNotFound : StatusCode::kIoError,
                  path + ": cannot open: " + std::strerror(errno));
  }
  // One read into a buffer of the file's size (a stream copy grows and
  // copies its buffer: a quarter of a second for 70 MB of SDFs), then
  // whatever is left if the file grew since it was measured.
  std::string contents(error ? 0 : static_cast<size_t>(size), '\0');
  in.read(contents.data(), static_cast<std::streamsize>(contents.size()));
  contents.resize(static_cast<size_t>(in.gcount()));
  if (in.bad()) return Status::IoError(path + ": read failed");
  if (in) {
    std::ostringstream rest;
    rest << in.rdbuf();
    if (in.bad()) return Status::IoError(path + ": read failed");
    contents += rest.str();
    if (contents.size() > max_bytes) {
      return Status::InvalidArgument(path + ": more than the " + std::to_string(max_bytes) +
                                     " bytes this file may have");
    }
  }
  return contents;
}

MappedFile::MappedFile(const std::string& path, unsigned long long max_bytes) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) return;
  struct stat status;
  if (::fstat(fd, &status) == 0 && S_ISREG(status.st_mode) && status.st_size > 0 &&
      static_cast<unsigned long long>(status.st_size) <= max_bytes) {
    // Populated at once: faulting 70 MB in page by page costs more than a read.
    void* data = ::mmap(nullptr, static_cast<size_t>(status.st_size), PROT_READ, MAP_PRIVATE | MAP_POPULATE, fd, 0);
    if (data != MAP_FAILED) {
      data_ = data;
      size_ = static_cast<size_t>(status.st_size);
    }
  }
  ::close(fd);
}

MappedFile::~MappedFile() {
  if (data_ != nullptr) ::munmap(data_, size_);
}

Status WriteFileAtomically(const std::string& path, const std::string& contents) {
  AtomicFileSet set;
  QUADHAND_RETURN_IF_ERROR(set.Stage(path, contents));
  return set.Commit();
}

Status CheckOutputPath(const std::string& path) {
  namespace fs = std::filesystem;
  if (path.empty()) return Status::InvalidArgument("an output path is empty");
  std::error_code error;
  const fs::file_status status = fs::symlink_status(path, error);
  if (error || !fs::exists(status)) return Status::Ok();
  if (fs::is_symlink(status)) {
    return Status::InvalidArgument(path + ": is a symbolic link; give the path of the file itself as the output");
  }
  if (fs::is_directory(status)) return Status::InvalidArgument(path + ": is a directory, not an output file");
  if (!fs::is_regular_file(status)) {
    return Status::InvalidArgument(path + ": is not a regular file (a device, FIFO or socket); refusing to replace it");
  }
  return Status::Ok();
}

namespace {

// Whether a new file can be made in `path`'s folder: a uniquely named probe
// is created and removed at once (permissions alone do not tell: root may
// "write" to /proc, where no file can be made).
Status CheckOutputFolder(const std::string& path) {
  namespace fs = std::filesystem;
  const std::string folder = DirectoryOf(path);
  std::error_code error;
  if (!fs::is_directory(folder, error)) return Status::InvalidArgument(path + ": its folder " + folder + " does not exist");
  static std::atomic<unsigned> counter{0};
  const std::string probe =
      (fs::path(folder) / (".quadhand-probe-" + std::to_string(getpid()) + "-" + std::to_string(counter++))).string();
  const int fd = open(probe.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
  if (fd < 0) {
    return Status::InvalidArgument(path + ": cannot create a file in " + folder + " (" + std::strerror(errno) + ")");
  }
  close(fd);
  unlink(probe.c_str());
  return Status::Ok();
}

}  // namespace

Status CheckFolderCanBeMade(const std::string& dir) {
  namespace fs = std::filesystem;
  std::error_code error;
  std::vector<fs::path> missing;  // the folders made here, deepest first
  for (fs::path p = fs::path(dir).lexically_normal(); !p.empty() && !fs::exists(p, error); p = p.parent_path()) {
    missing.push_back(p);
    if (p == p.parent_path()) break;
  }
  fs::create_directories(dir, error);
  const bool made = fs::is_directory(dir, error);
  for (const fs::path& p : missing) fs::remove(p, error);
  return made ? Status::Ok() : Status::InvalidArgument(dir + ": cannot create the output folder");
}

Status CheckOutputPathAndFolder(const std::string& path) {
  QUADHAND_RETURN_IF_ERROR(CheckOutputPath(path));
  return CheckOutputFolder(path);
}

bool SameFile(const std::string& a, const std::string& b) {
  namespace fs = std::filesystem;
  std::error_code error;
  if (fs::exists(a, error) && fs::exists(b, error) && fs::equivalent(a, b, error) && !error) return true;
  error.clear();
  const fs::path canonical_a = fs::weakly_canonical(fs::absolute(a, error), error);
  if (error) return false;
  const fs::path canonical_b = fs::weakly_canonical(fs::absolute(b, error), error);
  return !error && canonical_a == canonical_b;
}

AtomicFileSet::~AtomicFileSet() {
  for (const auto& [temporary, final_path] : staged_) std::remove(temporary.c_str());
  for (int slot : slots_) UnregisterTemporary(slot);
}

Status AtomicFileSet::Stage(const std::string& path, const std::string& contents) {
  QUADHAND_RETURN_IF_ERROR(CheckOutputPath(path));
  for (const auto& [temporary, final_path] : staged_) {
    if (SameFile(path, final_path)) {
      return Status::InvalidArgument(path + ": given for two outputs (" + final_path + " is the other)");
    }
  }
  for (const std::string& input : protected_) {
    if (SameFile(path, input)) return Status::InvalidArgument(path + ": is an input of this run; refusing to overwrite it");
  }
  const std::string temporary = TemporaryNameFor(path);
  slots_.push_back(RegisterTemporary(temporary));
  QUADHAND_RETURN_IF_ERROR(WriteWholeFile(temporary, contents));
  staged_.emplace_back(temporary, path);
  return Status::Ok();
}

Status AtomicFileSet::Commit() {
  for (size_t i = 0; i < staged_.size(); ++i) {
    const auto& [temporary, final_path] = staged_[i];
    if (std::rename(temporary.c_str(), final_path.c_str()) != 0) {
      const std::string reason = std::strerror(errno);
      const std::string failed = final_path;  // the erase below invalidates the reference
      // Files renamed before the failure stay: they are complete, only the set is not.
      staged_.erase(staged_.begin(), staged_.begin() + static_cast<long>(i));
      return Status::IoError(failed + ": cannot rename into place: " + reason);
    }
  }
  staged_.clear();
  return Status::Ok();
}

GrowingFile::GrowingFile(std::string path) : path_(std::move(path)) {}

GrowingFile::~GrowingFile() {
  if (file_ != nullptr) std::fclose(file_);
}

void GrowingFile::Append(const std::string& text) {
  if (!error_.empty()) return;
  if (file_ == nullptr) {
    file_ = std::fopen(partial_path().c_str(), "w");
    if (file_ == nullptr) {
      error_ = partial_path() + ": cannot create it";
      return;
    }
  }
  if (std::fwrite(text.data(), 1, text.size(), file_) != text.size() || std::fflush(file_) != 0) {
    error_ = partial_path() + ": cannot write it (disk full?)";
  }
}

Status GrowingFile::Finish() {
  if (file_ == nullptr && error_.empty()) Append("");
  if (file_ != nullptr && std::fclose(file_) != 0 && error_.empty()) error_ = partial_path() + ": cannot write it";
  file_ = nullptr;
  if (error_.empty() && std::rename(partial_path().c_str(), path_.c_str()) != 0) {
    error_ = path_ + ": cannot rename " + partial_path() + " to it";
  }
  return error_.empty() ? Status::Ok() : Status::InvalidArgument(error_);
}

std::string DirectoryOf(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  if (slash == std::string::npos) return ".";
  if (slash == 0) return "/";
  return path.substr(0, slash);
}

std::string ResolvePath(const std::string& base_dir, const std::string& relative) {
  if (relative.empty() || relative[0] == '/') return relative;
  if (base_dir.empty() || base_dir == ".") return relative;
  return base_dir + "/" + relative;
}

std::string FindBundledFile(const std::string& relative, const std::string& source_dir) {
  auto exists = [](const std::string& path) { return access(path.c_str(), F_OK) == 0; };
  if (exists(relative)) return relative;
  std::vector<std::string> candidates;
  char exe[4096];
  const ssize_t n = readlink("/proc/self/exe", exe, sizeof(exe) - 1);
  if (n > 0) {
    exe[n] = '\0';
    candidates.push_back(DirectoryOf(DirectoryOf(exe)) + "/share/quadhand/" + relative);
  }
  if (!source_dir.empty()) candidates.push_back(source_dir + "/" + relative);
  for (const std::string& candidate : candidates) {
    if (exists(candidate)) return candidate;
  }
  return relative;
}

}  // namespace quadhand::core
