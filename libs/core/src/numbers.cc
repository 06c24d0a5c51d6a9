#include "quadhand/core/numbers.h"

namespace quadhand::core {

bool ParseWholeNumber(const std::string& text, std::uint64_t limit, std::uint64_t* value) {
  if (text.empty()) return false;
  std::uint64_t parsed = 0;
  for (char c : text) {
    if (c < '0' || c > '9') return false;
    const std::uint64_t digit = static_cast<std::uint64_t>(c - '0');
    if (parsed > (limit - digit) / 10) return false;  // parsed * 10 + digit > limit, without overflow
    parsed = parsed * 10 + digit;
  }
  *value = parsed;
  return true;
}

}  // namespace quadhand::core
