// Checks of YAML text that every reader of a YAML file applies before its
// own parse (yaml-cpp itself is seen only by the .cc files that read YAML).
#pragma once

#include <string>

#include "quadhand/core/status.h"

namespace quadhand::core {

// InvalidArgument naming `name` and the line when the text is not YAML, when
// a mapping holds the same key twice (yaml-cpp would keep the first and drop
// the second silently: "safety_distance: 0.03 ... safety_distance: 0.1"
// must not plan with 0.03), when it nests deeper than 64 levels, or when it
// holds more than 100 000 nodes counting each use of an alias (an alias bomb).
Status CheckYamlText(const std::string& text, const std::string& name);

}  // namespace quadhand::core
