// The simulator configuration YAML (quadhand-sim --config); the robot path
// is resolved but never opened by the parser.
#include <string>

#include "quadhand/sim/config.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  auto config = quadhand::sim::ParseSimConfig(text, "/nonexistent-quadhand-fuzz", "fuzz_sim.yaml");
  (void)config;
  return 0;
}
