// Runs a shell command for CLI tests, capturing its exit code, stdout and stderr.
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

namespace quadhand::testing {

struct CommandResult {
  int exit_code = -1;
  std::string out;
  std::string err;
};

inline std::string ReadAll(const std::string& path) {
  std::ifstream in(path);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

// `command` runs under /bin/sh; `stdin_text` is fed to its standard input.
inline CommandResult RunCommand(const std::string& command, const std::string& stdin_text = "") {
  static int counter = 0;
  const std::string base = "/tmp/quadhand_cmd_" + std::to_string(getpid()) + "_" + std::to_string(counter++);
  {
    std::ofstream in(base + ".in");
    in << stdin_text;
  }
  const std::string full = command + " <" + base + ".in >" + base + ".out 2>" + base + ".err";
  const int status = std::system(full.c_str());
  CommandResult result;
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  result.out = ReadAll(base + ".out");
  result.err = ReadAll(base + ".err");
  std::remove((base + ".in").c_str());
  std::remove((base + ".out").c_str());
  std::remove((base + ".err").c_str());
  return result;
}

// Number of lines in `text` (a final line without newline counts).
inline int CountLines(const std::string& text) {
  int lines = 0;
  for (char c : text) lines += c == '\n';
  if (!text.empty() && text.back() != '\n') ++lines;
  return lines;
}

}  // namespace quadhand::testing
