// The reference robot with coarse link SDFs (4 mm, 5 cm padding), generated
// once per test binary: enough for gradient and behaviour tests, fast to build.
#pragma once

#include <string>
#include <vector>

#include "quadhand/geometry/mesh_to_sdf.h"
#include "quadhand/robot/link_meshes.h"
#include "quadhand/robot/robot_model.h"

namespace quadhand::testing {

struct QuadHandFixture {
  robot::RobotModel robot;
  std::vector<int> links;  // collision links
  std::vector<geometry::SdfGrid> grids;
};

inline const std::string& QuadHandUrdfPath() {
  static const std::string path = std::string(QUADHAND_SOURCE_DIR) + "/meshes/quadhand/quadhand.urdf";
  return path;
}

inline const QuadHandFixture& CoarseQuadHand() {
  static const QuadHandFixture fixture = [] {
    QuadHandFixture f{*robot::RobotModel::LoadFromUrdfFile(QuadHandUrdfPath()), {}, {}};
    geometry::SdfGenerationOptions options;
    options.resolution = 0.004;
    options.padding = 0.05;
    for (int link : f.robot.CollisionLinks()) {
      f.links.push_back(link);
      f.grids.push_back(*geometry::GenerateSdf(*robot::LinkCollisionMesh(f.robot, link), f.robot.link(link).name,
                                               QuadHandUrdfPath(), options));
    }
    return f;
  }();
  return fixture;
}

// Central difference of f at 0 along one coordinate, and whether f is smooth
// across the step. Trilinear SDFs have gradient jumps on cell faces, where no
// finite difference can match the (one-sided) analytic gradient: callers skip
// those coordinates and bound how many they skip.
inline bool SmoothCentralDifference(const std::function<double(double)>& f, double step, double* derivative) {
  const double f0 = f(0.0), fp = f(step), fm = f(-step);
  const double forward = (fp - f0) / step, backward = (f0 - fm) / step;
  *derivative = (fp - fm) / (2 * step);
  return std::abs(forward - backward) <= 1e-4 * std::max(1.0, std::abs(*derivative));
}

}  // namespace quadhand::testing
