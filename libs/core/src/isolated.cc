#include "quadhand/core/isolated.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <new>

namespace quadhand::core {
namespace {


bool WriteAll(int fd, const char* data, std::size_t size) {
  while (size > 0) {
    const ssize_t written = write(fd, data, size);
    if (written < 0 && errno == EINTR) continue;
    if (written <= 0) return false;
    data += written;
    size -= static_cast<std::size_t>(written);
  }
  return true;
}

// The child: limits, the work, one tag byte ('O' result, 'E' error) and the
// bytes, then _exit (no destructors or atexit handlers of the parent's state).
[[noreturn]] void RunChild(int fd, const std::function<Result<std::string>()>& work, const std::string& what,
                           const IsolationLimits& limits) {
  if (!BuiltWithAddressSanitizer()) {
    const rlimit memory{static_cast<rlim_t>(limits.memory_bytes), static_cast<rlim_t>(limits.memory_bytes)};
    setrlimit(RLIMIT_AS, &memory);
  }
  std::string out;
  try {
    Result<std::string> result = work();
    out = result.ok() ? "O" + *result : "E" + result.status().message();
  } catch (const std::bad_alloc&) {
    out = "E" + what + ": needs more memory than the " + std::to_string(limits.memory_bytes >> 20) + " MiB it may use";
  } catch (const std::exception& e) {
    out = "E" + what + ": threw: " + e.what();
  } catch (...) {
    out = "E" + what + ": threw an exception";
  }
  _exit(WriteAll(fd, out.data(), out.size()) ? 0 : 3);
}

}  // namespace

bool BuiltWithAddressSanitizer() {
#if defined(__SANITIZE_ADDRESS__)
  return true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
  return true;
#else
  return false;
#endif
#else
  return false;
#endif
}

Result<std::string> RunIsolated(const std::function<Result<std::string>()>& work, const std::string& what,
                                const IsolationLimits& limits) {
  int fds[2];
  if (pipe2(fds, O_CLOEXEC) != 0) return Status::Internal(what + ": cannot create a pipe: " + std::strerror(errno));
  const pid_t pid = fork();
  if (pid < 0) {
    close(fds[0]);
    close(fds[1]);
    return Status::Internal(what + ": cannot start a child process: " + std::strerror(errno));
  }
  if (pid == 0) {
    close(fds[0]);
    RunChild(fds[1], work, what, limits);
  }
  close(fds[1]);
  std::string bytes;
  bool timed_out = false;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(limits.seconds);
  char buffer[65536];
  for (;;) {
    const double left = std::chrono::duration<double>(deadline - std::chrono::steady_clock::now()).count();
    if (left <= 0.0) {
      timed_out = true;
      break;
    }
    pollfd p{fds[0], POLLIN, 0};
    const int ready = poll(&p, 1, static_cast<int>(std::min(left, 1.0) * 1000.0) + 1);
    if (ready < 0 && errno == EINTR) continue;
    if (ready <= 0) continue;
    const ssize_t got = read(fds[0], buffer, sizeof(buffer));
    if (got < 0 && errno == EINTR) continue;
    if (got <= 0) break;  // end of file: the child is done (or died)
    bytes.append(buffer, static_cast<std::size_t>(got));
  }
  close(fds[0]);
  if (timed_out) kill(pid, SIGKILL);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (timed_out) return Status::InvalidArgument(what + ": took longer than " + std::to_string(int(limits.seconds)) + " s");
  if (WIFSIGNALED(status)) {
    const char* name = strsignal(WTERMSIG(status));
    return Status::InvalidArgument(what + ": crashed (" + std::string(name != nullptr ? name : "signal") + ")");
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || bytes.empty()) {
    return Status::InvalidArgument(what + ": stopped without a result (exit " +
                                   std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1) + ")");
  }
  if (bytes[0] == 'E') return Status::InvalidArgument(bytes.substr(1));
  return bytes.substr(1);
}

}  // namespace quadhand::core
