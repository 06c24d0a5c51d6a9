#include "quadhand/core/ply_header.h"

#include "quadhand/core/numbers.h"

namespace quadhand::core {
namespace {

constexpr std::size_t kMaxHeaderBytes = 65536;

std::vector<std::string> Words(const std::string& line) {
  std::vector<std::string> words;
  std::string word;
  for (char c : line) {
    if (c == ' ' || c == '\t') {
      if (!word.empty()) words.push_back(word);
      word.clear();
    } else {
      word += c;
    }
  }
  if (!word.empty()) words.push_back(word);
  return words;
}

std::string Printable(const std::string& word) {
  std::string out;
  for (char c : word.substr(0, 24)) out += (c >= 0x20 && c < 0x7f) ? c : '?';
  return out;
}

}  // namespace

int PlyTypeSize(const std::string& type) {
  if (type == "char" || type == "uchar" || type == "int8" || type == "uint8") return 1;
  if (type == "short" || type == "ushort" || type == "int16" || type == "uint16") return 2;
  if (type == "int" || type == "uint" || type == "float" || type == "int32" || type == "uint32" || type == "float32") {
    return 4;
  }
  if (type == "double" || type == "float64") return 8;
  return 0;
}

Result<PlyHeader> ParsePlyHeader(const std::string& bytes, std::uint64_t file_size) {
  PlyHeader header;
  std::size_t at = 0;
  int number = 0;
  auto fail = [&number](const std::string& what) {
    return Status::InvalidArgument("PLY header line " + std::to_string(number) + ": " + what);
  };
  for (;;) {
    const std::size_t end = bytes.find('\n', at);
    if (end == std::string::npos || end >= kMaxHeaderBytes) {
      return Status::InvalidArgument(bytes.size() >= kMaxHeaderBytes || end != std::string::npos
                                         ? "PLY header longer than 64 KiB"
                                         : "PLY header has no end_header");
    }
    std::string line = bytes.substr(at, end - at);
    at = end + 1;
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    for (char c : line) {
      if (static_cast<unsigned char>(c) < 0x20 && c != '\t') return fail("control character");
    }
    const std::vector<std::string> words = Words(line);
    if (number == 1) {
      if (words.size() != 1 || words[0] != "ply") return Status::InvalidArgument("not a PLY file (no 'ply' first line)");
      continue;
    }
    if (words.empty()) return fail("empty line");
    const std::string& keyword = words[0];
    if (keyword == "comment" || keyword == "obj_info") continue;
    if (keyword == "format") {
      if (!header.format.empty()) return fail("a second format line");
      if (words.size() != 3 || (words[1] != "ascii" && words[1] != "binary_little_endian" &&
                                words[1] != "binary_big_endian")) {
        return fail("format must be ascii, binary_little_endian or binary_big_endian with a version");
      }
      header.format = words[1];
    } else if (keyword == "element") {
      PlyElement element;
      if (words.size() != 3 || !ParseWholeNumber(words[2], file_size, &element.count)) {
        return fail("element needs a name and a whole-number count the file could hold");
      }
      element.name = words[1];
      header.elements.push_back(element);
    } else if (keyword == "property") {
      if (header.elements.empty()) return fail("property before any element");
      PlyProperty property;
      if (words.size() == 3 && PlyTypeSize(words[1]) > 0) {
        property.type = words[1];
        property.name = words[2];
      } else if (words.size() == 5 && words[1] == "list" && PlyTypeSize(words[2]) > 0 && PlyTypeSize(words[3]) > 0 &&
                 words[2].find("float") == std::string::npos && words[2] != "double") {
        property.is_list = true;
        property.count_type = words[2];
        property.type = words[3];
        property.name = words[4];
      } else {
        return fail("property must be 'property TYPE NAME' or 'property list COUNT_TYPE ITEM_TYPE NAME' with PLY "
                    "types");
      }
      header.elements.back().properties.push_back(property);
    } else if (keyword == "end_header") {
      if (words.size() != 1) return fail("end_header with more on the line");
      break;
    } else {
      return fail("unknown keyword '" + Printable(keyword) + "'");
    }
  }
  if (header.format.empty()) return Status::InvalidArgument("PLY header has no format line");
  header.header_bytes = at;
  // Every row takes some bytes: a binary one its fixed-size values (and a
  // list's length), an ascii one at least a value and a line end.
  const long double rest = file_size > at ? static_cast<long double>(file_size - at) : 0.0L;
  long double needed = 0.0L;
  for (const PlyElement& element : header.elements) {
    long double row = 0.0L;
    for (const PlyProperty& p : element.properties) row += PlyTypeSize(p.is_list ? p.count_type : p.type);
    if (header.format == "ascii") row = element.properties.empty() ? 0.0L : 2.0L;
    needed += row * element.count;
  }
  if (needed > rest) {
    return Status::InvalidArgument("the PLY header's element counts need more data than the file holds");
  }
  return header;
}

}  // namespace quadhand::core
