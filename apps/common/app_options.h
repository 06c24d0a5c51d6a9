// Command-line options that several QuadHand programs take, declared once so
// that each reads, checks and documents them the same way.
#pragma once

#include <string>
#include <vector>

namespace CLI {
class App;
}  // namespace CLI

namespace quadhand::apps {

// --package-path DIR[,DIR...] (repeatable): folders searched for
// package://NAME/ mesh URIs of the robot's URDF before ROS_PACKAGE_PATH.
// Each must be an existing folder (else CLI11's error, exit 2). After
// parsing, pass *dirs to robot::PrependRosPackagePath before loading a URDF.
void AddPackagePathOption(CLI::App* app, std::vector<std::string>* dirs);

}  // namespace quadhand::apps
