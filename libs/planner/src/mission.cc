#include "quadhand/planner/mission.h"

#include <algorithm>
#include <cmath>

#include "quadhand/geometry/primitives.h"

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

double DistanceToObjectSurface(const MissionObject& object, const Vec3& x) {
  const ObjectShape& s = object.shape;
  switch (s.kind) {
    case ObjectShape::Kind::kBox:
      return std::max(0.0, geometry::SignedDistance(geometry::Box{object.pose, s.box_size}, x));
    case ObjectShape::Kind::kCylinder:
      return std::max(0.0, geometry::SignedDistance(geometry::Cylinder{object.pose, s.radius, s.length}, x));
    case ObjectShape::Kind::kSphere:
      return std::max(0.0, geometry::SignedDistance(geometry::Sphere{object.pose.translation(), s.radius}, x));
    case ObjectShape::Kind::kMesh:
      break;
  }
  return (x - object.pose.translation()).norm();
}

InsertionGoal InsertionOf(const ToolGoal& tool, int tool_link) {
  InsertionGoal insertion;
  insertion.enabled = tool.has_insertion;
  insertion.tool_link = tool_link;
  insertion.tool_position = tool.position;
  insertion.tool_orientation = tool.orientation;
  insertion.direction = tool.insertion_direction;
  insertion.length = tool.insertion_length;
  return insertion;
}

}  // namespace quadhand::planner
