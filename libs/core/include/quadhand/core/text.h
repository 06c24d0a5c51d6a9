// printf-style formatting into a std::string, for messages and reports.
#pragma once

#include <string>
#include <vector>

namespace quadhand::core {

// The whole text printf would print for `format` and its arguments (no fixed
// buffer to cut a long message short). The compiler checks the arguments
// against the format.
std::string Format(const char* format, ...) __attribute__((format(printf, 1, 2)));

// `text` without its leading and trailing spaces, tabs and carriage returns.
std::string Trimmed(const std::string& text);

// The fields of one line of comma-separated values, as they are (not
// trimmed); a trailing comma ends in an empty field.
std::vector<std::string> SplitCommas(const std::string& line);
// The same fields, each Trimmed.
std::vector<std::string> TrimmedFields(const std::string& line);

}  // namespace quadhand::core
