// Upper bounds on how fast any point of the robot's collision geometry can
// move over a time interval of a whole-body trajectory: what the post-check's
// continuous-time certificate (docs/certificate.md) needs to turn clearances
// measured at two instants into a lower bound for every instant between them.
//
// A point P of link L moves at
//   v_P = v_B + w x (P - p_B) + sum_j qdot_j a_j x (P - o_j)   (revolute j)
//                             + sum_j qdot_j a_j               (prismatic j)
// over the joints j between the base and L, so
//   |v_P| <= V + W r_L + sum_k Qdot_k l_{L,k}
// with V, W, Qdot_k bounds of the base speed, the body rate and the joint
// rates over the interval, r_L a bound of |P - p_B| and l_{L,k} the lever of
// coordinate k (a bound of |P - o_j| times the mimic multiplier; 1 for a
// prismatic joint) - the levers from the URDF's joint offsets and the link's
// bounding box, valid in every configuration. The rates are bounded from the
// trajectory's polynomials (a Taylor expansion about the interval's middle,
// exact for a polynomial) and the body rate from differential flatness
// (traj/flatness.h): |w| <= |z_dot| (1 + sqrt((1 - c) / (1 + c))) + |psi_dot|,
// |z_dot| <= |jerk| / thrust, c the body z axis's vertical component.
#pragma once

#include <limits>
#include <vector>

#include "quadhand/env/exact_mesh_model.h"
#include "quadhand/planner/whole_body_problem.h"
#include "quadhand/robot/robot_model.h"

namespace quadhand::planner {

struct PointSpeedBound {
  // m/s: no point of any collision link moves faster in the world frame.
  double world = std::numeric_limits<double>::infinity();
  // m/s: no two points of two collision links approach each other faster
  // (the base's translation moves both alike and drops out).
  double relative = std::numeric_limits<double>::infinity();
};

class RobotMotionBound {
 public:
  // The levers of every link `exact` has geometry for (its link-frame boxes
  // bound the geometry). Infinite where a prismatic joint has no limits.
  RobotMotionBound(const robot::RobotModel& robot, const env::ExactMeshModel& exact);

  // Bounds over [t0, t1] (clamped to the trajectory), infinite where the
  // attitude is not defined by flatness throughout (thrust at or below the
  // free-fall threshold, or the body within the near-inverted tolerance).
  PointSpeedBound Over(const WholeBodyTrajectory& trajectory, double t0, double t1) const;

 private:
  struct LinkLevers {
    double base = 0.0;         // r_L, metres
    std::vector<double> joint;  // l_{L,k} per actuated coordinate, metres (1 for prismatic)
  };
  std::vector<LinkLevers> links_;
  int num_coordinates_ = 0;
};

}  // namespace quadhand::planner
