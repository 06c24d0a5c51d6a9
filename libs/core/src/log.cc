#include "quadhand/core/log.h"

#include <unistd.h>

#include <atomic>
#include <cstdarg>

namespace quadhand::core {
namespace {
std::atomic<int> g_log_level{static_cast<int>(LogLevel::kInfo)};

void VLog(LogLevel level, const char* format, va_list args) {
  if (static_cast<int>(level) > g_log_level.load()) return;
  std::vfprintf(stderr, format, args);
  std::fputc('\n', stderr);
}
}  // namespace

void SetLogLevel(LogLevel level) { g_log_level = static_cast<int>(level); }
LogLevel GetLogLevel() { return static_cast<LogLevel>(g_log_level.load()); }

void PrintError(const char* program, const std::string& message) {
  std::string line;
  line.reserve(message.size());
  for (const char c : message) {
    const unsigned char u = static_cast<unsigned char>(c);
    if (c == '\n') {
      line += "\\n";
    } else if (c == '\r') {
      line += "\\r";
    } else if (c == '\t') {
      line += "\\t";
    } else if (u < 0x20 || u == 0x7f) {
      char escaped[8];
      std::snprintf(escaped, sizeof(escaped), "\\x%02x", u);
      line += escaped;
    } else {
      line += c;
    }
  }
  std::fprintf(stderr, "%s: error: %s\n", program, line.c_str());
}

void LogInfo(const char* format, ...) {
  va_list args;
  va_start(args, format);
  VLog(LogLevel::kInfo, format, args);
  va_end(args);
}

void LogVerbose(const char* format, ...) {
  va_list args;
  va_start(args, format);
  VLog(LogLevel::kVerbose, format, args);
  va_end(args);
}

ProgressBar::ProgressBar(std::string label, long total)
    : label_(std::move(label)),
      total_(total > 0 ? total : 1),
      is_terminal_(isatty(STDERR_FILENO) != 0),
      start_(std::chrono::steady_clock::now()) {}

void ProgressBar::Update(long done) {
  if (GetLogLevel() == LogLevel::kQuiet || finished_) return;
  const int percent = static_cast<int>(100 * done / total_);
  const int step = is_terminal_ ? 1 : 10;
  if (percent / step == last_percent_ / step && done < total_) return;
  last_percent_ = percent;
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  std::fprintf(stderr, "%s%s %3d%% (%ld/%ld) %.1f s%s", is_terminal_ ? "\r" : "", label_.c_str(),
               percent, done, total_, seconds, is_terminal_ ? "" : "\n");
  std::fflush(stderr);
}

void ProgressBar::Finish() {
  if (finished_) return;
  if (last_percent_ < 100) Update(total_);
  finished_ = true;
  if (is_terminal_ && GetLogLevel() != LogLevel::kQuiet) std::fputc('\n', stderr);
}

}  // namespace quadhand::core
