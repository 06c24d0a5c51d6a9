// Minimal leveled logging to stderr and a terminal-aware progress reporter.
// Library code reports progress through callbacks; apps decide what to print.
#pragma once

#include <chrono>
#include <cstdio>
#include <string>

namespace quadhand::core {

enum class LogLevel { kQuiet = 0, kInfo = 1, kVerbose = 2 };

void SetLogLevel(LogLevel level);
LogLevel GetLogLevel();

// printf-style messages to stderr, printed when the level allows it.
void LogInfo(const char* format, ...) __attribute__((format(printf, 1, 2)));
void LogVerbose(const char* format, ...) __attribute__((format(printf, 1, 2)));

// Prints "<program>: error: <message>" as exactly one line on stderr: line
// breaks and other control characters in the message (a file name may hold
// them) are written as \n, \r, \t or \xHH.
void PrintError(const char* program, const std::string& message);

// Prints "label  42% (done/total) 1.2 s" on stderr, redrawn in place on a
// terminal and at most every 10 % otherwise (so logs stay short).
class ProgressBar {
 public:
  ProgressBar(std::string label, long total);
  void Update(long done);
  void Finish();

 private:
  std::string label_;
  long total_;
  int last_percent_ = -1;
  bool is_terminal_;
  bool finished_ = false;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace quadhand::core
