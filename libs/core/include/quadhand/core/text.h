// printf-style formatting into a std::string, for messages and reports.
#pragma once

#include <string>

namespace quadhand::core {

// The whole text printf would print for `format` and its arguments (no fixed
// buffer to cut a long message short). The compiler checks the arguments
// against the format.
std::string Format(const char* format, ...) __attribute__((format(printf, 1, 2)));

}  // namespace quadhand::core
