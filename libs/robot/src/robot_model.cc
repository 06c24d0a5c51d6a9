#include "quadhand/robot/robot_model.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <limits>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <utility>

#include <console_bridge/console.h>
#include <tinyxml.h>
#include <urdf_parser/urdf_parser.h>

#include "quadhand/core/file_util.h"

#include "xml_document.h"

namespace quadhand::robot {
namespace {

namespace fs = std::filesystem;
using core::Result;
using core::Status;

constexpr double kInf = std::numeric_limits<double>::infinity();

// urdfdom reports why a parse failed only through console_bridge. This
// handler keeps the error lines instead of printing them, so the caller gets
// one Status line and nothing reaches the terminal.
class CapturingOutputHandler : public console_bridge::OutputHandler {
 public:
  void log(const std::string& text, console_bridge::LogLevel level, const char* /*filename*/,
           int /*line*/) override {
    if (level >= console_bridge::CONSOLE_BRIDGE_LOG_ERROR) messages.push_back(text);
  }
  std::vector<std::string> messages;
};

// console_bridge's handler and level are process-wide: loads are serialised
// and the previous handler and level are restored afterwards.
std::mutex& ConsoleBridgeMutex() {
  static std::mutex mutex;
  return mutex;
}

class ScopedConsoleCapture {
 public:
  explicit ScopedConsoleCapture(CapturingOutputHandler* handler)
      : lock_(ConsoleBridgeMutex()), previous_level_(console_bridge::getLogLevel()) {
    console_bridge::useOutputHandler(handler);
    // Errors only: urdfdom's warnings ("no multiplier, using default") are noise.
    console_bridge::setLogLevel(console_bridge::CONSOLE_BRIDGE_LOG_ERROR);
  }
  ~ScopedConsoleCapture() {
    console_bridge::restorePreviousOutputHandler();
    console_bridge::setLogLevel(previous_level_);
  }
  ScopedConsoleCapture(const ScopedConsoleCapture&) = delete;
  ScopedConsoleCapture& operator=(const ScopedConsoleCapture&) = delete;

 private:
  std::lock_guard<std::mutex> lock_;
  console_bridge::LogLevel previous_level_;
};

// One line: newlines and runs of blanks collapsed, surrounding blanks trimmed.
std::string OneLine(const std::string& text) {
  std::string out;
  bool blank = false;
  for (char c : text) {
    if (c == '\n' || c == '\r' || c == '\t' || c == ' ') {
      blank = !out.empty();
      continue;
    }
    if (blank) out += ' ';
    blank = false;
    out += c;
  }
  return out;
}

std::string Join(const std::vector<std::string>& parts, const std::string& separator) {
  std::string out;
  for (const std::string& part : parts) {
    if (part.empty()) continue;
    if (!out.empty()) out += separator;
    out += part;
  }
  return out;
}

bool StartsWith(const std::string& text, const std::string& prefix) {
  return text.compare(0, prefix.size(), prefix) == 0;
}

// URDF writes quarter turns as decimals (rpy 1.5707963267948966), which leave
// residues of 1e-16 where the intended rotation has exact zeros. Geometry
// meant to be coplanar (a cylinder's cap on a box face) then comes out a
// hair apart, and the exact mesh union yields slivers that do not survive
// rounding to double. A rotation within 1e-12 of a signed permutation is
// therefore taken to be exactly that permutation.
Mat3 SnapQuarterTurns(const Mat3& rotation) {
  const Mat3 snapped = rotation.array().round().matrix();
  if ((rotation - snapped).cwiseAbs().maxCoeff() < 1e-12) return snapped;
  return rotation;
}

Pose ToPose(const urdf::Pose& pose) {
  const Quat rotation = Quat(pose.rotation.w, pose.rotation.x, pose.rotation.y, pose.rotation.z)
                            .normalized();
  return MakePose(Vec3(pose.position.x, pose.position.y, pose.position.z),
                  SnapQuarterTurns(rotation.toRotationMatrix()));
}

Vec3 ToVec3(const urdf::Vector3& v) { return Vec3(v.x, v.y, v.z); }

// No part of a robot is a kilometre from its parent or a kilometre wide: a
// larger length is a unit error or a corrupted file, and lengths near the
// limits of a double make every later distance meaningless.
constexpr double kMaxLength = 1000.0;

// Empty when the origin is finite, within kMaxLength and has a usable
// rotation; else what is wrong with it.
std::string OriginProblem(const urdf::Pose& pose) {
  const Vec3 position(pose.position.x, pose.position.y, pose.position.z);
  if (!position.allFinite() || position.cwiseAbs().maxCoeff() > kMaxLength) {
    return "origin xyz must be finite and within " + std::to_string(int(kMaxLength)) + " m";
  }
  const Eigen::Vector4d q(pose.rotation.w, pose.rotation.x, pose.rotation.y, pose.rotation.z);
  if (!q.allFinite() || !(q.norm() > 1e-9)) return "origin rpy must be finite";
  return "";
}

// ---------------------------------------------------------------------------
// package:// resolution

// The <name> of a ROS package.xml, or "" if the file is absent or unreadable.
std::string PackageXmlName(const fs::path& package_xml) {
  std::error_code error;
  if (!fs::is_regular_file(package_xml, error)) return "";
  TiXmlDocument doc;
  if (!doc.LoadFile(package_xml.string())) return "";
  const TiXmlElement* package = doc.FirstChildElement("package");
  const TiXmlElement* name = package ? package->FirstChildElement("name") : nullptr;
  if (name == nullptr || name->GetText() == nullptr) return "";
  return OneLine(name->GetText());
}

bool IsPackageRoot(const fs::path& dir, const std::string& package) {
  return dir.filename() == package || PackageXmlName(dir / "package.xml") == package;
}

bool IsDirectory(const fs::path& path) {
  std::error_code error;
  return fs::is_directory(path, error);
}

// Candidates, nearest first: the URDF's folder and each ancestor (the folder
// itself named NAME, or with a package.xml naming NAME, or holding a folder
// NAME), then each ROS_PACKAGE_PATH entry (the same tests, plus the package.xml
// of its immediate subfolders, which covers the usual workspace/src layout
// without crawling whole trees).
std::optional<fs::path> FindPackage(const std::string& package, const std::string& base_dir) {
  std::error_code error;
  fs::path start = fs::absolute(base_dir.empty() ? fs::path(".") : fs::path(base_dir), error);
  if (!error) {
    start = start.lexically_normal();
    if (start.filename().empty()) start = start.parent_path();  // trailing slash
    for (fs::path dir = start;; dir = dir.parent_path()) {
      if (IsPackageRoot(dir, package)) return dir;
      if (IsDirectory(dir / package)) return dir / package;
      if (dir == dir.root_path() || dir.parent_path() == dir) break;
    }
  }
  const char* ros_package_path = std::getenv("ROS_PACKAGE_PATH");
  if (ros_package_path == nullptr) return std::nullopt;
  std::string entries = ros_package_path;
  size_t begin = 0;
  while (begin <= entries.size()) {
    size_t end = entries.find(':', begin);
    if (end == std::string::npos) end = entries.size();
    const fs::path entry = entries.substr(begin, end - begin);
    begin = end + 1;
    if (entry.empty() || !IsDirectory(entry)) continue;
    if (IsPackageRoot(entry, package)) return entry;
    if (IsDirectory(entry / package)) return entry / package;
    for (fs::directory_iterator it(entry, error), last; !error && it != last; it.increment(error)) {
      if (IsDirectory(it->path()) && PackageXmlName(it->path() / "package.xml") == package) {
        return it->path();
      }
    }
  }
  return std::nullopt;
}

}  // namespace

void PrependRosPackagePath(const std::vector<std::string>& dirs) {
  if (dirs.empty()) return;
  std::string value;
  for (const std::string& dir : dirs) value += (value.empty() ? "" : ":") + dir;
  if (const char* existing = std::getenv("ROS_PACKAGE_PATH"); existing != nullptr && *existing != '\0') {
    value += std::string(":") + existing;
  }
  setenv("ROS_PACKAGE_PATH", value.c_str(), /*overwrite=*/1);
}

namespace {

Result<std::string> ResolveMeshPath(const std::string& filename, const std::string& base_dir) {
  if (StartsWith(filename, "package://")) {
    const std::string rest = filename.substr(std::string("package://").size());
    const size_t slash = rest.find('/');
    const std::string package = rest.substr(0, slash);
    if (package.empty()) {
      return Status::InvalidArgument("mesh '" + filename + "': no package name");
    }
    const std::optional<fs::path> root = FindPackage(package, base_dir);
    if (!root) {
      return Status::NotFound("mesh '" + filename + "': package '" + package +
                              "' not found among the ancestors of '" + base_dir +
                              "' or on ROS_PACKAGE_PATH");
    }
    if (slash == std::string::npos) return root->string();
    return (*root / rest.substr(slash + 1)).string();
  }
  if (StartsWith(filename, "file://")) {
    return core::ResolvePath(base_dir, filename.substr(std::string("file://").size()));
  }
  const size_t scheme = filename.find("://");
  if (scheme != std::string::npos) {
    return Status::InvalidArgument("mesh '" + filename +
                                   "': unsupported URI scheme (use package://, file:// or a path)");
  }
  return core::ResolvePath(base_dir, filename);
}

// ---------------------------------------------------------------------------
// Conversion of urdfdom's model

Result<CollisionGeometry> ConvertCollision(const urdf::Collision& collision,
                                           const std::string& base_dir) {
  CollisionGeometry geometry;
  if (const std::string problem = OriginProblem(collision.origin); !problem.empty()) {
    return Status::InvalidArgument("collision " + problem);
  }
  geometry.origin = ToPose(collision.origin);
  const urdf::Geometry& shape = *collision.geometry;
  switch (shape.type) {
    case urdf::Geometry::SPHERE: {
      geometry.type = GeometryType::kSphere;
      geometry.radius = static_cast<const urdf::Sphere&>(shape).radius;
      if (!(geometry.radius > 0.0 && geometry.radius <= kMaxLength)) {
        return Status::InvalidArgument("sphere radius must be positive and at most 1000 m");
      }
      break;
    }
    case urdf::Geometry::BOX: {
      geometry.type = GeometryType::kBox;
      geometry.box_size = ToVec3(static_cast<const urdf::Box&>(shape).dim);
      if (!(geometry.box_size.array() > 0.0).all() || !(geometry.box_size.array() <= kMaxLength).all()) {
        return Status::InvalidArgument("box size must be positive and at most 1000 m");
      }
      break;
    }
    case urdf::Geometry::CYLINDER: {
      const auto& cylinder = static_cast<const urdf::Cylinder&>(shape);
      geometry.type = GeometryType::kCylinder;
      geometry.radius = cylinder.radius;
      geometry.length = cylinder.length;
      if (!(geometry.radius > 0.0 && geometry.length > 0.0 && geometry.radius <= kMaxLength &&
            geometry.length <= kMaxLength)) {
        return Status::InvalidArgument("cylinder radius and length must be positive and at most 1000 m");
      }
      break;
    }
    case urdf::Geometry::MESH: {
      const auto& mesh = static_cast<const urdf::Mesh&>(shape);
      geometry.type = GeometryType::kMesh;
      geometry.mesh_scale = ToVec3(mesh.scale);
      if (!(geometry.mesh_scale.array().abs() > 0.0).all()) {
        return Status::InvalidArgument("mesh '" + mesh.filename + "': scale must be non-zero");
      }
      // Wider than metres from micrometres (or the reverse) is a typo: a
      // 1e-300 scale flattened a link into a sheet the exact check could not
      // see, a 1e300 one overflowed CGAL's distances.
      if (!(geometry.mesh_scale.array().abs() >= 1e-6 && geometry.mesh_scale.array().abs() <= 1e6).all()) {
        return Status::InvalidArgument("mesh '" + mesh.filename + "': scale entries must be within [1e-6, 1e6] in magnitude");
      }
      Result<std::string> path = ResolveMeshPath(mesh.filename, base_dir);
      if (!path.ok()) return path.status();
      geometry.mesh_path = std::move(path).value();
      break;
    }
  }
  return geometry;
}

Result<Link> ConvertLink(const urdf::Link& source, const std::string& base_dir) {
  Link link;
  link.name = source.name;
  std::vector<urdf::CollisionSharedPtr> collisions = source.collision_array;
  if (collisions.empty() && source.collision) collisions.push_back(source.collision);
  for (const urdf::CollisionSharedPtr& collision : collisions) {
    if (!collision || !collision->geometry) continue;
    Result<CollisionGeometry> geometry = ConvertCollision(*collision, base_dir);
    if (!geometry.ok()) {
      return Status(geometry.status().code(),
                    "link '" + link.name + "': collision: " + geometry.status().message());
    }
    link.collisions.push_back(std::move(geometry).value());
  }
  if (source.inertial) {
    const urdf::Inertial& inertial = *source.inertial;
    if (!(inertial.mass >= 0.0)) {
      return Status::InvalidArgument("link '" + link.name + "': negative mass");
    }
    link.mass = inertial.mass;
    // URDF gives the inertia about the CoM in the axes of the inertial origin
    // frame; consumers want link-frame axes: I_L = R I_C R^T.
    const Pose X_LC = ToPose(inertial.origin);
    Mat3 inertia_c;
    inertia_c << inertial.ixx, inertial.ixy, inertial.ixz,  //
        inertial.ixy, inertial.iyy, inertial.iyz,           //
        inertial.ixz, inertial.iyz, inertial.izz;
    link.center_of_mass = X_LC.translation();
    link.inertia = X_LC.linear() * inertia_c * X_LC.linear().transpose();
  }
  return link;
}

Result<Joint> ConvertJoint(const urdf::Joint& source) {
  Joint joint;
  joint.name = source.name;
  const std::string where = "joint '" + joint.name + "': ";
  switch (source.type) {
    case urdf::Joint::REVOLUTE: joint.type = JointType::kRevolute; break;
    case urdf::Joint::CONTINUOUS: joint.type = JointType::kContinuous; break;
    case urdf::Joint::PRISMATIC: joint.type = JointType::kPrismatic; break;
    case urdf::Joint::FIXED: joint.type = JointType::kFixed; break;
    case urdf::Joint::FLOATING:
      return Status::InvalidArgument(where + "unsupported joint type 'floating'");
    case urdf::Joint::PLANAR:
      return Status::InvalidArgument(where + "unsupported joint type 'planar'");
    default:
      return Status::InvalidArgument(where + "unknown joint type");
  }
  if (const std::string problem = OriginProblem(source.parent_to_joint_origin_transform); !problem.empty()) {
    return Status::InvalidArgument(where + problem);
  }
  joint.origin = ToPose(source.parent_to_joint_origin_transform);
  // Scaled by its largest entry before normalising: the squared norm of an
  // axis like (0, 1e300, 0) overflows, and normalized() then returns a zero
  // axis, a joint that silently does nothing.
  Vec3 axis = ToVec3(source.axis);
  if (!axis.allFinite()) return Status::InvalidArgument(where + "axis must be finite");
  const double largest = axis.cwiseAbs().maxCoeff();
  if (joint.type != JointType::kFixed && !(largest > 1e-12)) return Status::InvalidArgument(where + "zero axis");
  if (largest > 1e-12) joint.axis = (axis / largest).normalized();
  if (source.limits) joint.max_velocity = source.limits->velocity;
  switch (joint.type) {
    case JointType::kRevolute:
    case JointType::kPrismatic:
      joint.lower = source.limits ? source.limits->lower : -kInf;
      joint.upper = source.limits ? source.limits->upper : kInf;
      if (joint.lower > joint.upper) {
        return Status::InvalidArgument(where + "lower limit above upper limit");
      }
      break;
    case JointType::kContinuous:
      joint.lower = -kInf;
      joint.upper = kInf;
      break;
    case JointType::kFixed:
      joint.max_velocity = 0.0;
      break;
  }
  if (joint.max_velocity < 0.0) return Status::InvalidArgument(where + "negative velocity limit");
  // A mimic element on a fixed joint has nothing to drive: it is ignored.
  if (source.mimic && joint.type != JointType::kFixed) {
    joint.is_mimic = true;
    joint.mimic_multiplier = source.mimic->multiplier;
    joint.mimic_offset = source.mimic->offset;
  }
  return joint;
}

// The names of the <joint> children of <robot> in document order. urdfdom
// keeps joints in a std::map (alphabetical), but q must follow the file.
// Only direct children count, as for urdfdom: <transmission> also has
// <joint name=...> elements.
std::vector<std::string> JointNamesInDocumentOrder(const TiXmlElement& robot) {
  std::vector<std::string> names;
  for (const TiXmlElement* joint = robot.FirstChildElement("joint"); joint != nullptr;
       joint = joint->NextSiblingElement("joint")) {
    const char* name = joint->Attribute("name");
    if (name != nullptr) names.emplace_back(name);
  }
  return names;
}

}  // namespace

// ---------------------------------------------------------------------------

Result<RobotModel> RobotModel::LoadFromUrdfFile(const std::string& path) {
  std::error_code error;
  if (fs::is_directory(path, error)) return Status::IoError(path + ": is a directory, not a URDF");
  Result<std::string> xml = core::ReadFileToString(path);
  if (!xml.ok()) return xml.status();
  return Load(*xml, core::DirectoryOf(path), path);
}

Result<RobotModel> RobotModel::LoadFromUrdfString(const std::string& xml,
                                                  const std::string& base_dir) {
  return Load(xml, base_dir, "URDF string");
}

Result<RobotModel> RobotModel::Load(const std::string& xml, const std::string& base_dir,
                                    const std::string& source) {
  auto invalid = [&source](const std::string& problem) {
    return Status::InvalidArgument(source + ": " + problem);
  };

  // Our own XML pass first: it gives line and column for malformed XML, which
  // urdfdom does not, and the document order of the joints.
  TiXmlDocument doc;
  if (std::string problem = ParseXmlDocument(xml, &doc); !problem.empty()) return invalid(problem);
  const TiXmlElement* robot_xml = doc.FirstChildElement("robot");
  if (robot_xml == nullptr) return invalid("no <robot> element");
  const std::vector<std::string> document_order = JointNamesInDocumentOrder(*robot_xml);

  urdf::ModelInterfaceSharedPtr urdf_model;
  {
    CapturingOutputHandler handler;
    std::string exception_text;
    {
      ScopedConsoleCapture capture(&handler);
      try {
        urdf_model = urdf::parseURDF(xml);
      } catch (const std::exception& e) {
        // urdfdom throws from a few number-parsing paths; not ours to propagate.
        exception_text = e.what();
      }
    }
    // urdfdom logs some errors and carries on without the offending element
    // (a collision with an unparsable size, an inertial without inertia):
    // a robot silently missing collision geometry is worse than no robot.
    if (!urdf_model || !handler.messages.empty()) {
      std::vector<std::string> messages;
      for (const std::string& message : handler.messages) messages.push_back(OneLine(message));
      messages.push_back(OneLine(exception_text));
      const std::string why = Join(messages, "; ");
      return invalid(why.empty() ? "invalid URDF" : why);
    }
  }

  // Joints in document order; any urdfdom knows that our scan missed (not
  // expected) follow in name order so nothing is silently dropped.
  std::vector<urdf::JointSharedPtr> joints_in_order;
  std::set<std::string> seen;
  for (const std::string& name : document_order) {
    auto it = urdf_model->joints_.find(name);
    if (it != urdf_model->joints_.end() && seen.insert(name).second) {
      joints_in_order.push_back(it->second);
    }
  }
  for (const auto& [name, joint] : urdf_model->joints_) {
    if (seen.insert(name).second) joints_in_order.push_back(joint);
  }

  // The tree: each link's parent joint, children in document order.
  std::map<std::string, urdf::JointSharedPtr> parent_joint_of;
  std::map<std::string, std::vector<urdf::JointSharedPtr>> child_joints_of;
  for (const urdf::JointSharedPtr& joint : joints_in_order) {
    if (joint->parent_link_name == joint->child_link_name) {
      return invalid("joint '" + joint->name + "' connects link '" + joint->parent_link_name +
                     "' to itself (kinematic loop)");
    }
    auto [it, inserted] = parent_joint_of.emplace(joint->child_link_name, joint);
    if (!inserted) {
      return invalid("link '" + joint->child_link_name + "' is the child of two joints, '" +
                     it->second->name + "' and '" + joint->name + "' (kinematic loop)");
    }
    child_joints_of[joint->parent_link_name].push_back(joint);
  }
  if (!urdf_model->getRoot()) return invalid("no root link");
  const std::string root_name = urdf_model->getRoot()->name;

  RobotModel model;
  model.name_ = urdf_model->getName();

  // Depth-first preorder from the root, children in document order: parents
  // precede children and joint j is the parent joint of link j + 1.
  std::map<std::string, int> link_index;
  std::map<std::string, int> joint_index;
  std::vector<std::pair<std::string, urdf::JointSharedPtr>> stack = {{root_name, nullptr}};
  while (!stack.empty()) {
    auto [link_name, parent_joint] = stack.back();
    stack.pop_back();
    auto urdf_link = urdf_model->links_.find(link_name);
    if (urdf_link == urdf_model->links_.end()) {
      return invalid("link '" + link_name + "' is used by a joint but not defined");
    }
    Result<Link> link = ConvertLink(*urdf_link->second, base_dir);
    if (!link.ok()) return Status(link.status().code(), source + ": " + link.status().message());
    const int index = static_cast<int>(model.links_.size());
    link_index[link_name] = index;
    if (parent_joint) {
      Result<Joint> joint = ConvertJoint(*parent_joint);
      if (!joint.ok()) return invalid(joint.status().message());
      joint->parent_link = link_index.at(parent_joint->parent_link_name);
      joint->child_link = index;
      link->parent_joint = static_cast<int>(model.joints_.size());
      joint_index[joint->name] = link->parent_joint;
      model.joints_.push_back(std::move(joint).value());
    }
    model.links_.push_back(std::move(link).value());
    auto children = child_joints_of.find(link_name);
    if (children != child_joints_of.end()) {
      for (auto child = children->second.rbegin(); child != children->second.rend(); ++child) {
        stack.emplace_back((*child)->child_link_name, *child);
      }
    }
  }
  if (model.links_.size() != urdf_model->links_.size()) {
    std::vector<std::string> unreachable;
    for (const auto& [name, link] : urdf_model->links_) {
      if (link_index.count(name) == 0) unreachable.push_back("'" + name + "'");
    }
    return invalid("links " + Join(unreachable, ", ") + " are not reachable from the root '" +
                   root_name + "' (kinematic loop)");
  }

  // Actuated joints in document order.
  for (const urdf::JointSharedPtr& urdf_joint : joints_in_order) {
    const int j = joint_index.at(urdf_joint->name);
    Joint& joint = model.joints_[j];
    if (joint.type == JointType::kFixed || joint.is_mimic) continue;
    joint.q_index = static_cast<int>(model.actuated_joints_.size());
    model.actuated_joints_.push_back(j);
  }

  // Mimic joints: follow the chain to an actuated joint, composing
  // position = m * source + o at each step, so FK needs one lookup.
  for (Joint& joint : model.joints_) {
    if (!joint.is_mimic) continue;
    const urdf::JointSharedPtr& urdf_joint = urdf_model->joints_.at(joint.name);
    std::string source_name = urdf_joint->mimic->joint_name;
    double multiplier = joint.mimic_multiplier;
    double offset = joint.mimic_offset;
    for (int steps = 0;; ++steps) {
      auto found = joint_index.find(source_name);
      if (found == joint_index.end()) {
        return invalid("joint '" + joint.name + "' mimics unknown joint '" + source_name + "'");
      }
      const Joint& source_joint = model.joints_[found->second];
      if (source_joint.type == JointType::kFixed) {
        return invalid("joint '" + joint.name + "' mimics fixed joint '" + source_name + "'");
      }
      if (!source_joint.is_mimic) {
        joint.q_index = source_joint.q_index;
        break;
      }
      if (steps > model.num_joints()) {
        return invalid("joint '" + joint.name + "': mimic chain is a loop");
      }
      const urdf::JointMimic& next = *urdf_model->joints_.at(source_name)->mimic;
      offset += multiplier * next.offset;
      multiplier *= next.multiplier;
      source_name = next.joint_name;
    }
    joint.mimic_multiplier = multiplier;
    joint.mimic_offset = offset;
  }

  model.joints_to_link_.resize(model.links_.size());
  for (int l = 0; l < model.num_links(); ++l) {
    std::vector<int>& path = model.joints_to_link_[l];
    for (int j = model.links_[l].parent_joint; j >= 0;
         j = model.links_[model.joints_[j].parent_link].parent_joint) {
      path.push_back(j);
    }
    std::reverse(path.begin(), path.end());
  }
  return model;
}

core::Result<RobotModel> RobotModel::WithFixedLink(int parent, const std::string& joint_name, Link link,
                                                   const Pose& origin) const {
  if (parent < 0 || parent >= num_links()) return core::Status::InvalidArgument("fixed link: no parent link " + std::to_string(parent));
  if (LinkIndex(link.name) >= 0) return core::Status::InvalidArgument("fixed link: the robot has a link named '" + link.name + "' already");
  if (JointIndex(joint_name) >= 0) {
    return core::Status::InvalidArgument("fixed link: the robot has a joint named '" + joint_name + "' already");
  }
  if (!origin.matrix().allFinite()) return core::Status::InvalidArgument("fixed link '" + link.name + "': non-finite origin");
  RobotModel model = *this;
  Joint joint;
  joint.name = joint_name;
  joint.type = JointType::kFixed;
  joint.parent_link = parent;
  joint.child_link = num_links();
  joint.origin = origin;
  link.parent_joint = num_joints();
  model.joints_.push_back(joint);
  model.links_.push_back(std::move(link));
  std::vector<int> path = joints_to_link_[parent];
  path.push_back(joint.child_link - 1);
  model.joints_to_link_.push_back(std::move(path));
  return model;
}

int RobotModel::LinkIndex(const std::string& name) const {
  for (int i = 0; i < num_links(); ++i) {
    if (links_[i].name == name) return i;
  }
  return -1;
}

int RobotModel::JointIndex(const std::string& name) const {
  for (int i = 0; i < num_joints(); ++i) {
    if (joints_[i].name == name) return i;
  }
  return -1;
}

std::vector<std::string> RobotModel::ActuatedJointNames() const {
  std::vector<std::string> names;
  for (int j : actuated_joints_) names.push_back(joints_[j].name);
  return names;
}

VecX RobotModel::LowerLimits() const {
  VecX limits(num_actuated());
  for (int k = 0; k < num_actuated(); ++k) limits[k] = joints_[actuated_joints_[k]].lower;
  return limits;
}

VecX RobotModel::UpperLimits() const {
  VecX limits(num_actuated());
  for (int k = 0; k < num_actuated(); ++k) limits[k] = joints_[actuated_joints_[k]].upper;
  return limits;
}

VecX RobotModel::VelocityLimits() const {
  VecX limits(num_actuated());
  for (int k = 0; k < num_actuated(); ++k) limits[k] = joints_[actuated_joints_[k]].max_velocity;
  return limits;
}

std::vector<int> RobotModel::CollisionLinks() const {
  std::vector<int> links;
  for (int l = 0; l < num_links(); ++l) {
    if (!links_[l].collisions.empty()) links.push_back(l);
  }
  return links;
}

double RobotModel::TotalMass() const {
  double mass = 0.0;
  for (const Link& link : links_) mass += link.mass;
  return mass;
}

}  // namespace quadhand::robot
