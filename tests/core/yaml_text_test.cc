#include "quadhand/core/yaml_text.h"

#include <gtest/gtest.h>

#include <string>

namespace quadhand::core {
namespace {

TEST(YamlTextTest, RejectsDuplicateKeysAtAnyDepthNamingTheLines) {
  EXPECT_TRUE(CheckYamlText("a: 1\nb: {c: 2, d: 3}\nlist:\n  - {x: 1}\n  - {x: 2}\n", "t.yaml").ok());
  const Status top = CheckYamlText("safety_distance: 0.03\nrobot: r.urdf\nsafety_distance: 0.1\n", "t.yaml");
  ASSERT_FALSE(top.ok());
  EXPECT_EQ(top.message(), "t.yaml: line 3: duplicate key 'safety_distance' (first on line 1)");
  const Status nested = CheckYamlText("goal:\n  tool:\n    position: [0, 0, 1]\n    position: [1, 0, 1]\n", "t.yaml");
  ASSERT_FALSE(nested.ok());
  EXPECT_NE(nested.message().find("line 4: duplicate key 'position'"), std::string::npos) << nested.message();
  const Status in_list = CheckYamlText("scene:\n  - {file: a.pcd, file: b.pcd}\n", "t.yaml");
  EXPECT_FALSE(in_list.ok());
}

TEST(YamlTextTest, RejectsMalformedAndTooDeepText) {
  const Status broken = CheckYamlText("robot: [unclosed\n", "t.yaml");
  ASSERT_FALSE(broken.ok());
  EXPECT_NE(broken.message().find("t.yaml: not valid YAML"), std::string::npos) << broken.message();
  std::string deep;
  for (int i = 0; i < 100; ++i) deep += "[";
  for (int i = 0; i < 100; ++i) deep += "]";
  const Status too_deep = CheckYamlText(deep, "t.yaml");
  ASSERT_FALSE(too_deep.ok());
  EXPECT_NE(too_deep.message().find("nested more than 64"), std::string::npos) << too_deep.message();
  EXPECT_TRUE(CheckYamlText("", "empty.yaml").ok());
}

// Nine aliases of nine aliases, nine levels deep: 300 bytes that expand to
// 9^9 (387 million) nodes. yaml-cpp shares aliased nodes, but every reader
// walking the tree visits them all: it was a hang of every program that
// reads YAML. Refused after 100 000 node visits; an ordinary use of aliases
// is still fine.
TEST(YamlTextTest, RefusesAnAliasBombAndKeepsOrdinaryAliases) {
  std::string bomb = "a: &a [lol, lol, lol, lol, lol, lol, lol, lol, lol]\n";
  for (char level = 'b'; level <= 'i'; ++level) {
    const char previous = static_cast<char>(level - 1);
    bomb += std::string(1, level) + ": &" + level + " [";
    for (int k = 0; k < 9; ++k) bomb += std::string(k ? ", " : "") + "*" + previous;
    bomb += "]\n";
  }
  const Status refused = CheckYamlText(bomb, "bomb.yaml");
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.message().find("bomb.yaml: line "), std::string::npos) << refused.message();
  EXPECT_NE(refused.message().find("more than 100000 nodes"), std::string::npos) << refused.message();
  EXPECT_TRUE(CheckYamlText("limits: &l {v_max: 2, a_max: 4}\nother: *l\nthird: *l\n", "t.yaml").ok());
}

}  // namespace
}  // namespace quadhand::core
