// Shared by the libFuzzer targets (scripts/fuzz.sh, docs/reliability.md):
// readers that take a path get the input written to a file of this process.
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>

namespace quadhand::fuzz {

// Writes `size` bytes to a file named `name` in a folder of this process
// (made once, under $TMPDIR or /tmp) and returns its path.
inline std::string WriteInput(const uint8_t* data, size_t size, const std::string& name) {
  static const std::string folder = [] {
    const char* tmp = std::getenv("TMPDIR");
    std::string path = std::string(tmp != nullptr && *tmp != '\0' ? tmp : "/tmp") + "/quadhand-fuzz-XXXXXX";
    if (mkdtemp(path.data()) == nullptr) std::abort();
    return path;
  }();
  const std::string path = folder + "/" + name;
  std::FILE* out = std::fopen(path.c_str(), "wb");
  if (out == nullptr) std::abort();
  if (size > 0 && std::fwrite(data, 1, size, out) != size) std::abort();
  std::fclose(out);
  return path;
}

}  // namespace quadhand::fuzz
