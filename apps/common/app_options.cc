#include "app_options.h"

#include <CLI/CLI.hpp>

namespace quadhand::apps {

void AddPackagePathOption(CLI::App* app, std::vector<std::string>* dirs) {
  app->add_option("--package-path", *dirs,
                  "Folders searched for package://NAME/ mesh URIs before ROS_PACKAGE_PATH (repeatable or\n"
                  "comma separated; also the URDF's own ancestors are searched)")
      ->delimiter(',')
      ->check(CLI::ExistingDirectory);
}

}  // namespace quadhand::apps
