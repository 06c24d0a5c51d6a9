// The benchmark configuration YAML (quadhand-bench --config).
#include <string>

#include "quadhand/planner/bench_config.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  auto config = quadhand::planner::ParseBenchConfig(text, "/nonexistent-quadhand-fuzz/bench.yaml");
  (void)config;
  return 0;
}
