// core::ParsePlyHeader: the PLY header read strictly, before PCL or CGAL
// size anything from it.
#include "quadhand/core/ply_header.h"

#include <gtest/gtest.h>

namespace quadhand::core {
namespace {

TEST(PlyHeaderTest, ReadsAWellFormedHeader) {
  const std::string header =
      "ply\r\nformat binary_little_endian 1.0\ncomment from a scanner\nobj_info x\nelement vertex 2\n"
      "property float x\nproperty float y\nproperty double z\nproperty uchar red\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  const std::string data(2 * (4 + 4 + 8 + 1) + 1 + 3 * 4, '\0');
  auto parsed = ParsePlyHeader(header + data, header.size() + data.size());
  ASSERT_TRUE(parsed.ok()) << parsed.status().message();
  EXPECT_EQ(parsed->format, "binary_little_endian");
  ASSERT_EQ(parsed->elements.size(), 2u);
  EXPECT_EQ(parsed->elements[0].name, "vertex");
  EXPECT_EQ(parsed->elements[0].count, 2u);
  ASSERT_EQ(parsed->elements[0].properties.size(), 4u);
  EXPECT_EQ(parsed->elements[0].properties[2].type, "double");
  EXPECT_TRUE(parsed->elements[1].properties[0].is_list);
  EXPECT_EQ(parsed->elements[1].properties[0].count_type, "uchar");
  EXPECT_EQ(parsed->header_bytes, header.size());
}

// Each refused with a reason; the first is the fuzzer's input (a negative
// count PCL turned into a 34 GB allocation, and lines it matched loosely).
TEST(PlyHeaderTest, RefusesWhatPclAndCgalWouldMisread) {
  const std::string xyz = "property float x\nproperty float y\nproperty float z\n";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"ply\nformat binary_little_endian 1.0\nelement vertex -2\np\x1fropertye x\npr y\nproperty double z\n"
       "end_header\n",
       "element needs a name and a whole-number count"},
      {"ply\nformat ascii 1.0\nelement vertex 1\np\x1froperty float x\nend_header\n0\n", "control character"},
      {"ply\nformat ascii 1.0\nelement vertex 1\npr float x\nend_header\n0\n", "unknown keyword 'pr'"},
      {"ply\nformat ascii 1.0\nelement vertex 1\nproperty float64x x\nend_header\n0\n", "property must be"},
      {"ply\nformat ascii 1.0\nelement face 1\nproperty list float int v\nend_header\n0\n", "property must be"},
      {"ply\nformat ascii 1.0\nformat ascii 1.0\nelement vertex 1\n" + xyz + "end_header\n0 0 0\n",
       "a second format line"},
      {"ply\nformat binary_little_endian 1.0\nelement vertex 10\n" + xyz + "end_header\n" + std::string(12, '\0'),
       "need more data than the file holds"},
      {"ply\nformat ascii 1.0\nelement vertex 1\n" + xyz, "no end_header"},
      {"ply\nformat ascii 1.0\nelement vertex 1\n" + xyz + "end_header extra\n0 0 0\n", "end_header with more"},
      {"plyx\nformat ascii 1.0\n", "no 'ply' first line"},
      {"ply\nelement vertex 1\n" + xyz + "end_header\n0 0 0\n", "no format line"},
      {"ply\n" + std::string(70000, 'c') + "\n", "longer than 64 KiB"},
  };
  for (const auto& [text, fragment] : cases) {
    auto parsed = ParsePlyHeader(text, text.size());
    ASSERT_FALSE(parsed.ok()) << text.substr(0, 80);
    EXPECT_NE(parsed.status().message().find(fragment), std::string::npos) << parsed.status().message();
  }
}

}  // namespace
}  // namespace quadhand::core
