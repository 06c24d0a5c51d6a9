// Task YAML (docs/task_format.md), as quadhand-plan reads it, and the
// cautions the applications print about a task that parsed.
#include <string>

#include "quadhand/planner/task.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  auto task = quadhand::planner::ParseTaskText(text, "fuzz.yaml", "/nonexistent-quadhand-fuzz", {});
  if (task.ok()) (void)quadhand::planner::TaskCautions(*task);
  return 0;
}
