// Strict parsing of numbers in the text headers of third-party formats
// (PCD, PLY, OFF, Collada counts), where a lenient parse (a sign, spaces,
// "1e9", digits past the type's range) is how a file talks a reader into a
// huge allocation.
#pragma once

#include <cstdint>
#include <string>

namespace quadhand::core {

// True, with *value set, when `text` is a decimal whole number (digits only)
// no larger than `limit`.
bool ParseWholeNumber(const std::string& text, std::uint64_t limit, std::uint64_t* value);

}  // namespace quadhand::core
