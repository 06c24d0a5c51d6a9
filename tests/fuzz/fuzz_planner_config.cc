// The planner configuration YAML (docs/configuration.md).
#include <string>

#include "quadhand/planner/planner_config.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  auto config = quadhand::planner::ParsePlannerConfig(text, "fuzz.yaml");
  (void)config;
  return 0;
}
