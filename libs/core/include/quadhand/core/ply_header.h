// The header of a PLY file (scans and meshes), read strictly before PCL or
// CGAL see the file: both size their buffers from it and match its lines
// loosely (a negative element count became a 34 GB allocation in PCL; found
// by fuzzing).
//
//   ply
//   format ascii|binary_little_endian|binary_big_endian 1.0
//   comment ... | obj_info ...                 (anywhere)
//   element NAME COUNT
//   property TYPE NAME | property list COUNT_TYPE ITEM_TYPE NAME
//   end_header
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "quadhand/core/status.h"

namespace quadhand::core {

struct PlyProperty {
  std::string name;
  std::string type;        // char .. double, int8 .. float64; for a list, its items'
  bool is_list = false;
  std::string count_type;  // lists: the type of the length before each list
};

struct PlyElement {
  std::string name;
  std::uint64_t count = 0;
  std::vector<PlyProperty> properties;
};

struct PlyHeader {
  std::string format;  // "ascii", "binary_little_endian" or "binary_big_endian"
  std::vector<PlyElement> elements;
  std::uint64_t header_bytes = 0;  // up to and including the end_header line
};

// Bytes of one value of a PLY scalar type, 0 for an unknown type.
int PlyTypeSize(const std::string& type);

// Reads and checks the header of `bytes` (the file's first bytes, at least
// the header) for a file of `file_size` bytes: the lines above and nothing
// else, no control characters, the header within 64 KiB, and element counts
// the rest of the file can hold (a binary row takes its fixed-size
// properties' bytes, an ascii row at least two). Errors say what is wrong
// (callers add the file's name).
Result<PlyHeader> ParsePlyHeader(const std::string& bytes, std::uint64_t file_size);

}  // namespace quadhand::core
