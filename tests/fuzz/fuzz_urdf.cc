// URDF text (mesh paths point nowhere: the robot model alone is parsed).
#include <string>

#include "quadhand/robot/robot_model.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string xml(reinterpret_cast<const char*>(data), size);
  auto robot = quadhand::robot::RobotModel::LoadFromUrdfString(xml, "/nonexistent-quadhand-fuzz");
  (void)robot;
  return 0;
}
