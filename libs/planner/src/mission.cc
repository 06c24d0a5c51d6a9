#include "quadhand/planner/mission.h"

#include <cmath>

namespace quadhand::planner {

const char* StepKindName(StepKind kind) {
  switch (kind) {
    case StepKind::kReach:
      return "reach";
    case StepKind::kMove:
      return "move";
    case StepKind::kVia:
      return "via";
    case StepKind::kGrasp:
      return "grasp";
    case StepKind::kRelease:
      return "release";
    case StepKind::kHold:
      return "hold";
  }
  return "unknown";
}

double ObjectShape::BoundingRadius() const {
  switch (kind) {
    case Kind::kBox:
      return 0.5 * box_size.norm();
    case Kind::kCylinder:
      return std::hypot(radius, 0.5 * length);
    case Kind::kSphere:
      return radius;
    case Kind::kMesh:
      return 0.0;
  }
  return 0.0;
}

std::string StepName(const std::vector<MissionStep>& mission, size_t index) {
  return "mission[" + std::to_string(index) + "]" +
         (index < mission.size() ? std::string(" (") + StepKindName(mission[index].kind) + ")" : std::string());
}

}  // namespace quadhand::planner
