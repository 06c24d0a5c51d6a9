// A robot read from a URDF: links, joints (revolute, continuous, prismatic,
// fixed, mimic), collision geometry and inertial data. Immutable after loading.
//
// Indices: links and joints are numbered in topological order (a parent link
// always has a smaller index than its children; link 0 is the root, the
// floating base; joint j is the parent joint of link j + 1, depth-first with
// siblings in URDF order). "Actuated" joints are the non-fixed, non-mimic joints in the
// order they appear in the URDF file; a configuration vector q lists their
// positions in that order.
#pragma once

#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/core/types.h"

namespace quadhand::robot {

enum class JointType { kFixed, kRevolute, kContinuous, kPrismatic };

struct Joint {
  std::string name;
  JointType type = JointType::kFixed;
  int parent_link = -1;
  int child_link = -1;
  Pose origin = Pose::Identity();  // X_PJ: joint frame in the parent link frame
  Vec3 axis = Vec3::UnitX();       // unit axis in the joint (= child link) frame
  // Limits; +-infinity where the URDF gives none (continuous joints).
  double lower = 0.0;
  double upper = 0.0;
  double max_velocity = 0.0;  // 0 where the URDF gives none
  // Position in q of this joint's coordinate: itself if actuated, the source
  // joint's if mimic, -1 if fixed.
  int q_index = -1;
  bool is_mimic = false;
  double mimic_multiplier = 1.0;  // position = multiplier * q[q_index] + offset
  double mimic_offset = 0.0;
};

enum class GeometryType { kMesh, kBox, kCylinder, kSphere };

struct CollisionGeometry {
  GeometryType type = GeometryType::kMesh;
  Pose origin = Pose::Identity();  // X_LG: geometry frame in the link frame
  std::string mesh_path;           // absolute or cwd-relative, resolved (package://, relative)
  Vec3 mesh_scale = Vec3::Ones();
  Vec3 box_size = Vec3::Zero();    // full edge lengths
  double radius = 0.0;             // cylinder, sphere
  double length = 0.0;             // cylinder, along the geometry frame's z axis
};

struct Link {
  std::string name;
  int parent_joint = -1;  // -1 for the root
  std::vector<CollisionGeometry> collisions;
  double mass = 0.0;
  Vec3 center_of_mass = Vec3::Zero();  // in the link frame
  Mat3 inertia = Mat3::Zero();         // about the centre of mass, link-frame axes
};

// Puts `dirs` before the ROS_PACKAGE_PATH entries that package:// mesh URIs
// are resolved against (the programs' --package-path). It sets the
// process's environment: call it before loading, not while another thread
// loads a robot.
void PrependRosPackagePath(const std::vector<std::string>& dirs);

class RobotModel {
 public:
  // Loads a URDF file. Relative mesh paths resolve against the file's folder;
  // package://NAME/... against a folder NAME found among the file's ancestors
  // or on ROS_PACKAGE_PATH (an unresolvable package is an error here; a missing
  // mesh file is only found by whoever reads it); file:///abs is a plain path.
  // Errors name the file and the problem: NotFound/IoError for an unreadable
  // file, InvalidArgument for malformed XML, loops, unknown mimic sources and
  // unsupported (floating, planar) joints.
  static core::Result<RobotModel> LoadFromUrdfFile(const std::string& path);
  // Same from a string; `base_dir` plays the role of the file's folder.
  static core::Result<RobotModel> LoadFromUrdfString(const std::string& xml,
                                                     const std::string& base_dir);

  // This robot with one more link, `link` (its parent_joint is ignored),
  // fixed to `parent` at `origin` (X_PL) by a joint named `joint_name`: an
  // object held in the gripper (planner/mission.h). The new link is the
  // last (its index is num_links()), so every existing index stays valid.
  // InvalidArgument for an unknown parent, a name already taken, or a
  // non-finite origin.
  core::Result<RobotModel> WithFixedLink(int parent, const std::string& joint_name, Link link,
                                         const Pose& origin) const;

  const std::string& name() const { return name_; }

  int num_links() const { return static_cast<int>(links_.size()); }
  const Link& link(int index) const { return links_[index]; }
  int LinkIndex(const std::string& name) const;  // -1 if absent

  int num_joints() const { return static_cast<int>(joints_.size()); }
  const Joint& joint(int index) const { return joints_[index]; }
  int JointIndex(const std::string& name) const;  // -1 if absent

  // Actuated joints (the coordinates of q), in URDF order.
  int num_actuated() const { return static_cast<int>(actuated_joints_.size()); }
  const std::vector<int>& actuated_joints() const { return actuated_joints_; }
  std::vector<std::string> ActuatedJointNames() const;
  VecX LowerLimits() const;
  VecX UpperLimits() const;
  VecX VelocityLimits() const;  // 0 where the URDF gives none

  // Links with at least one collision geometry, in link order.
  std::vector<int> CollisionLinks() const;

  // Joints on the path from the root to `link`, root first.
  const std::vector<int>& JointsToLink(int link) const { return joints_to_link_[link]; }

  double TotalMass() const;

  // The tolerance the robot's collision meshes are repaired with, metres
  // (geometry::MeshRepairOptions::tolerance; LinkCollisionElements). The
  // SDF generator and the planner must use the same one, so that both see
  // the same geometry.
  double mesh_repair_tolerance() const { return mesh_repair_tolerance_; }
  void set_mesh_repair_tolerance(double metres) { mesh_repair_tolerance_ = metres; }

  // A folder of cached mesh repairs (geometry/repaired_mesh_cache.h) that
  // LinkCollisionElements reads before repairing a mesh file itself; empty
  // (the default): none. The planner sets it to the SDF folder's `meshes/`,
  // where quadhand-sdfgen writes them (robot::SaveMeshRepairCache).
  const std::string& mesh_cache_dir() const { return mesh_cache_dir_; }
  void set_mesh_cache_dir(std::string dir) { mesh_cache_dir_ = std::move(dir); }

 private:
  static core::Result<RobotModel> Load(const std::string& xml, const std::string& base_dir,
                                       const std::string& source);

  std::string name_;
  std::vector<Link> links_;
  std::vector<Joint> joints_;
  std::vector<int> actuated_joints_;
  std::vector<std::vector<int>> joints_to_link_;
  double mesh_repair_tolerance_ = 1e-6;
  std::string mesh_cache_dir_;
};

}  // namespace quadhand::robot
