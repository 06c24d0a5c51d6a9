#include "quadhand/core/text.h"

#include <gtest/gtest.h>

#include <string>

namespace quadhand::core {
namespace {

TEST(FormatTest, PrintsWhatPrintfPrints) {
  EXPECT_EQ(Format("%g m", 0.05), "0.05 m");
  EXPECT_EQ(Format("%s: scene[%zu] %.3f", "task.yaml", static_cast<size_t>(2), 1.0 / 3.0), "task.yaml: scene[2] 0.333");
  EXPECT_EQ(Format("%g", 1e300), "1e+300");
  EXPECT_EQ(Format("%s", ""), "");
}

TEST(FormatTest, ALongMessageIsWhole) {
  const std::string path(5000, 'a');
  const std::string text = Format("%s: %d", path.c_str(), 42);
  EXPECT_EQ(text.size(), 5004u);
  EXPECT_EQ(text.substr(text.size() - 4), ": 42");
}

}  // namespace
}  // namespace quadhand::core
