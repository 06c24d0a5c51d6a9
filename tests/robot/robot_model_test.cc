// Loading URDFs: structure, order, limits, mimic joints, geometry, inertia,
// path resolution and every error path, on the arm2 fixture (not QuadHand).
#include "quadhand/robot/robot_model.h"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "quadhand/robot/kinematics.h"
#include "robot/robot_test_util.h"

namespace quadhand::robot {
namespace {

namespace fs = std::filesystem;
using core::StatusCode;
using testing::Arm2Path;
using testing::FixturePath;

constexpr double kInf = std::numeric_limits<double>::infinity();

RobotModel LoadArm2() {
  auto model = RobotModel::LoadFromUrdfFile(Arm2Path());
  EXPECT_TRUE(model.ok()) << model.status().message();
  return std::move(model).value();
}

// URDF rotation from roll, pitch, yaw: fixed axes x, y, z.
Mat3 Rpy(double roll, double pitch, double yaw) {
  return (Eigen::AngleAxisd(yaw, Vec3::UnitZ()) * Eigen::AngleAxisd(pitch, Vec3::UnitY()) *
          Eigen::AngleAxisd(roll, Vec3::UnitX()))
      .toRotationMatrix();
}

bool SameFile(const std::string& a, const std::string& b) {
  std::error_code error;
  return fs::equivalent(a, b, error) && !error;
}

// Sets an environment variable for one scope and restores it afterwards.
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const std::string& value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old;
    setenv(name, value.c_str(), 1);
  }
  ~ScopedEnv() {
    if (old_) {
      setenv(name_, old_->c_str(), 1);
    } else {
      unsetenv(name_);
    }
  }

 private:
  const char* name_;
  std::optional<std::string> old_;
};

// A one-link robot with one extra fragment inside <robot>.
std::string OneLinkUrdf(const std::string& body) {
  return "<robot name='r'><link name='base'/>" + body + "</robot>";
}

std::string RevoluteJoint(const std::string& name, const std::string& parent,
                          const std::string& child, const std::string& extra = "") {
  return "<joint name='" + name + "' type='revolute'><parent link='" + parent +
         "'/><child link='" + child +
         "'/><axis xyz='0 0 1'/><limit lower='-1' upper='1' effort='1' velocity='1'/>" + extra +
         "</joint>";
}

// Loads a string that must fail, checks the code and that the message is one line.
core::Status LoadFailure(const std::string& xml, StatusCode expected) {
  auto model = RobotModel::LoadFromUrdfString(xml, FixturePath(""));
  EXPECT_FALSE(model.ok());
  if (model.ok()) return core::Status::Ok();
  EXPECT_EQ(model.status().code(), expected) << model.status().message();
  EXPECT_EQ(model.status().message().find('\n'), std::string::npos) << model.status().message();
  return model.status();
}

// An axis is a direction at any scale: (0, 1e300, 0) overflowed the squared
// norm and loaded as a zero axis, a joint that silently did nothing (the
// plan then failed on a misread robot). A zero axis is still refused.
TEST(RobotModelTest, AnAxisOfAnyScaleIsItsDirection) {
  for (const char* axis : {"0 1e300 0", "0 -1e200 0", "0 3 4"}) {
    SCOPED_TRACE(axis);
    const std::string joint = "<joint name='j' type='revolute'><parent link='base'/><child link='arm'/><axis xyz='" +
                              std::string(axis) + "'/><limit lower='-1' upper='1' effort='1' velocity='1'/></joint>";
    auto model = RobotModel::LoadFromUrdfString(OneLinkUrdf("<link name='arm'/>" + joint), FixturePath(""));
    ASSERT_TRUE(model.ok()) << model.status().message();
    const Vec3 expected = std::string(axis) == "0 3 4" ? Vec3(0, 0.6, 0.8) : std::string(axis) == "0 1e300 0" ? Vec3::UnitY() : Vec3(-Vec3::UnitY());
    EXPECT_TRUE(model->joint(model->JointIndex("j")).axis.isApprox(expected, 1e-15))
        << model->joint(model->JointIndex("j")).axis.transpose();
  }
  const core::Status zero = LoadFailure(OneLinkUrdf("<link name='arm'/><joint name='j' type='revolute'><parent "
                                                    "link='base'/><child link='arm'/><axis xyz='0 0 0'/><limit "
                                                    "lower='-1' upper='1' effort='1' velocity='1'/></joint>"),
                                        StatusCode::kInvalidArgument);
  EXPECT_NE(zero.message().find("zero axis"), std::string::npos) << zero.message();
}

TEST(RobotModelTest, LoadsLinksInTopologicalOrderRootFirst) {
  const RobotModel model = LoadArm2();
  EXPECT_EQ(model.name(), "arm2");
  ASSERT_EQ(model.num_links(), 7);
  ASSERT_EQ(model.num_joints(), 6);
  // Depth first, siblings in file order (slider is declared before flap_joint).
  const std::vector<std::string> links = {"base", "upper", "forearm", "hand",
                                          "tool", "flap",  "flap2"};
  for (int l = 0; l < model.num_links(); ++l) EXPECT_EQ(model.link(l).name, links[l]) << l;
  EXPECT_EQ(model.link(0).parent_joint, -1);
  for (int j = 0; j < model.num_joints(); ++j) {
    const Joint& joint = model.joint(j);
    EXPECT_EQ(joint.child_link, j + 1) << joint.name;
    EXPECT_LT(joint.parent_link, joint.child_link) << joint.name;
    EXPECT_EQ(model.link(joint.child_link).parent_joint, j) << joint.name;
  }
  EXPECT_EQ(model.joint(model.JointIndex("flap_joint")).parent_link, model.LinkIndex("upper"));
  EXPECT_EQ(model.LinkIndex("flap2"), 6);
  EXPECT_EQ(model.LinkIndex("nope"), -1);
  EXPECT_EQ(model.JointIndex("nope"), -1);
}

TEST(RobotModelTest, ActuatedJointsFollowDocumentOrder) {
  const RobotModel model = LoadArm2();
  // File order; neither alphabetical (shoulder, slider, wrist) nor topological.
  EXPECT_EQ(model.ActuatedJointNames(), (std::vector<std::string>{"wrist", "slider", "shoulder"}));
  ASSERT_EQ(model.num_actuated(), 3);
  for (int k = 0; k < model.num_actuated(); ++k) {
    EXPECT_EQ(model.joint(model.actuated_joints()[k]).q_index, k);
  }
  EXPECT_EQ(model.joint(model.JointIndex("tool_joint")).q_index, -1);
}

TEST(RobotModelTest, JointTypesLimitsAndAxes) {
  const RobotModel model = LoadArm2();
  const Joint& wrist = model.joint(model.JointIndex("wrist"));
  const Joint& slider = model.joint(model.JointIndex("slider"));
  const Joint& shoulder = model.joint(model.JointIndex("shoulder"));
  const Joint& tool = model.joint(model.JointIndex("tool_joint"));
  EXPECT_EQ(wrist.type, JointType::kContinuous);
  EXPECT_EQ(slider.type, JointType::kPrismatic);
  EXPECT_EQ(shoulder.type, JointType::kRevolute);
  EXPECT_EQ(tool.type, JointType::kFixed);

  // q = [wrist, slider, shoulder]; a continuous joint has no position limits.
  EXPECT_EQ(model.LowerLimits(), Eigen::Vector3d(-kInf, 0.0, -2.5));
  EXPECT_EQ(model.UpperLimits(), Eigen::Vector3d(kInf, 0.2, 2.5));
  EXPECT_EQ(model.VelocityLimits(), Eigen::Vector3d(4.0, 0.5, 1.5));

  EXPECT_TRUE(wrist.axis.isApprox(Vec3(1, 1, 0).normalized(), 1e-15));  // normalised on load
  EXPECT_TRUE(shoulder.axis.isApprox(Vec3::UnitZ()));
  EXPECT_TRUE(shoulder.origin.translation().isApprox(Vec3(0, 0, 0.1)));
  EXPECT_TRUE(shoulder.origin.linear().isApprox(Rpy(0.1, -0.2, 0.3), 1e-12));
  EXPECT_TRUE(tool.origin.linear().isApprox(Rpy(0, 0, 0.5), 1e-12));
  EXPECT_TRUE(wrist.origin.translation().isApprox(Vec3(0.15, 0, 0)));
}

TEST(RobotModelTest, MimicJointsResolveToTheirActuatedSource) {
  const RobotModel model = LoadArm2();
  const int wrist_q = model.joint(model.JointIndex("wrist")).q_index;
  const Joint& flap = model.joint(model.JointIndex("flap_joint"));
  EXPECT_TRUE(flap.is_mimic);
  EXPECT_EQ(flap.q_index, wrist_q);
  EXPECT_DOUBLE_EQ(flap.mimic_multiplier, 0.5);
  EXPECT_DOUBLE_EQ(flap.mimic_offset, 0.1);
  EXPECT_DOUBLE_EQ(flap.lower, -1.0);  // a mimic joint keeps its own URDF limits
  // Mimic of a mimic: -2 (0.5 w + 0.1) + 0.05 = -w - 0.15.
  const Joint& flap2 = model.joint(model.JointIndex("flap2_joint"));
  EXPECT_TRUE(flap2.is_mimic);
  EXPECT_EQ(flap2.type, JointType::kPrismatic);
  EXPECT_EQ(flap2.q_index, wrist_q);
  EXPECT_DOUBLE_EQ(flap2.mimic_multiplier, -1.0);
  EXPECT_DOUBLE_EQ(flap2.mimic_offset, -0.15);
  // Non-mimic joints map q one to one.
  const Joint& slider = model.joint(model.JointIndex("slider"));
  EXPECT_FALSE(slider.is_mimic);
  EXPECT_EQ(slider.mimic_multiplier, 1.0);
  EXPECT_EQ(slider.mimic_offset, 0.0);
}

TEST(RobotModelTest, JointsToLinkListsThePathRootFirst) {
  const RobotModel model = LoadArm2();
  EXPECT_TRUE(model.JointsToLink(0).empty());
  const std::vector<int> expected = {model.JointIndex("shoulder"), model.JointIndex("flap_joint"),
                                     model.JointIndex("flap2_joint")};
  EXPECT_EQ(model.JointsToLink(model.LinkIndex("flap2")), expected);
  const std::vector<int> to_tool = {model.JointIndex("shoulder"), model.JointIndex("slider"),
                                    model.JointIndex("wrist"), model.JointIndex("tool_joint")};
  EXPECT_EQ(model.JointsToLink(model.LinkIndex("tool")), to_tool);
}

TEST(RobotModelTest, AFixedLinkAddedLastMovesWithItsParent) {
  const RobotModel model = LoadArm2();
  const int tool = model.LinkIndex("tool");
  Link held;
  held.name = "held";
  CollisionGeometry sphere;
  sphere.type = GeometryType::kSphere;
  sphere.radius = 0.02;
  held.collisions.push_back(sphere);
  held.mass = 0.1;
  const Pose origin = MakePose(Vec3(0.0, 0.0, 0.05), Eigen::AngleAxisd(0.3, Vec3::UnitX()).toRotationMatrix());
  auto with = model.WithFixedLink(tool, "held_joint", held, origin);
  ASSERT_TRUE(with.ok()) << with.status().message();
  ASSERT_EQ(with->num_links(), model.num_links() + 1);
  ASSERT_EQ(with->num_joints(), model.num_joints() + 1);
  EXPECT_EQ(with->num_actuated(), model.num_actuated());
  const int link = with->num_links() - 1;
  EXPECT_EQ(with->LinkIndex("held"), link);
  EXPECT_EQ(with->link(link).parent_joint, with->num_joints() - 1);
  EXPECT_EQ(with->joint(with->num_joints() - 1).parent_link, tool);
  std::vector<int> path = model.JointsToLink(tool);
  path.push_back(with->num_joints() - 1);
  EXPECT_EQ(with->JointsToLink(link), path);
  EXPECT_DOUBLE_EQ(with->TotalMass(), model.TotalMass() + 0.1);
  EXPECT_EQ(with->CollisionLinks().back(), link);
  // Every configuration puts it at the parent's pose times its origin.
  const Pose base = MakePose(Vec3(1, 2, 3), Eigen::AngleAxisd(0.7, Vec3::UnitZ()).toRotationMatrix());
  const VecX q = VecX::LinSpaced(model.num_actuated(), 0.1, 0.3);
  const Pose expected = LinkPose(model, base, q, tool) * origin;
  EXPECT_TRUE(LinkPose(*with, base, q, link).isApprox(expected, 1e-12));
  // The robot it came from is unchanged.
  EXPECT_EQ(model.LinkIndex("held"), -1);

  EXPECT_FALSE(model.WithFixedLink(-1, "j", held, origin).ok());
  EXPECT_FALSE(model.WithFixedLink(model.num_links(), "j", held, origin).ok());
  EXPECT_FALSE(model.WithFixedLink(tool, "shoulder", held, origin).ok());  // a joint of that name exists
  held.name = "tool";
  EXPECT_FALSE(model.WithFixedLink(tool, "j", held, origin).ok());  // a link of that name exists
  held.name = "held";
  Pose bad = origin;
  bad.translation().x() = std::nan("");
  EXPECT_FALSE(model.WithFixedLink(tool, "j", held, bad).ok());
}

TEST(RobotModelTest, CollisionGeometry) {
  const RobotModel model = LoadArm2();
  EXPECT_EQ(model.CollisionLinks(), (std::vector<int>{0, 1, 2, 3, 5, 6}));  // not "tool"

  const Link& base = model.link(0);
  ASSERT_EQ(base.collisions.size(), 2u);
  EXPECT_EQ(base.collisions[0].type, GeometryType::kBox);
  EXPECT_TRUE(base.collisions[0].box_size.isApprox(Vec3(0.2, 0.2, 0.1)));
  EXPECT_EQ(base.collisions[1].type, GeometryType::kSphere);
  EXPECT_DOUBLE_EQ(base.collisions[1].radius, 0.06);
  EXPECT_TRUE(base.collisions[1].origin.translation().isApprox(Vec3(0, 0, 0.05)));

  const CollisionGeometry& cylinder = model.link(model.LinkIndex("upper")).collisions.at(0);
  EXPECT_EQ(cylinder.type, GeometryType::kCylinder);
  EXPECT_DOUBLE_EQ(cylinder.radius, 0.03);
  EXPECT_DOUBLE_EQ(cylinder.length, 0.3);
  // rpy (0, pi/2, 0) turns the cylinder's z axis onto the link's x axis.
  EXPECT_TRUE((cylinder.origin.linear() * Vec3::UnitZ()).isApprox(Vec3::UnitX(), 1e-12));
}

TEST(RobotModelTest, MeshPathsResolvePackageAndRelativeReferences) {
  const RobotModel model = LoadArm2();
  const std::string tetra = FixturePath("qh_fixture_pkg/meshes/tetra.off");
  // package://qh_fixture/...: found through package.xml's <name>.
  const CollisionGeometry& flap = model.link(model.LinkIndex("flap")).collisions.at(0);
  EXPECT_EQ(flap.type, GeometryType::kMesh);
  EXPECT_TRUE(SameFile(flap.mesh_path, tetra)) << flap.mesh_path;
  EXPECT_TRUE(flap.mesh_scale.isApprox(Vec3::Constant(0.1)));
  // package://qh_fixture_pkg/...: found as an ancestor folder of that name.
  const CollisionGeometry& flap2 = model.link(model.LinkIndex("flap2")).collisions.at(0);
  EXPECT_TRUE(SameFile(flap2.mesh_path, tetra)) << flap2.mesh_path;
  // ../meshes/tetra.off: relative to the URDF's folder.
  const CollisionGeometry& forearm = model.link(model.LinkIndex("forearm")).collisions.at(1);
  EXPECT_TRUE(SameFile(forearm.mesh_path, tetra)) << forearm.mesh_path;
  EXPECT_TRUE(forearm.origin.translation().isApprox(Vec3(0.08, 0, 0)));
}

TEST(RobotModelTest, PackageFoundOnRosPackagePath) {
  const std::string urdf =
      "<robot name='r'><link name='base'><collision><geometry>"
      "<mesh filename='package://qh_fixture/meshes/tetra.off'/></geometry></collision></link>"
      "</robot>";
  const std::string tetra = FixturePath("qh_fixture_pkg/meshes/tetra.off");
  {
    // Neither "/" nor its ancestors hold the package, and the path is empty.
    ScopedEnv env("ROS_PACKAGE_PATH", "");
    auto model = RobotModel::LoadFromUrdfString(urdf, "/");
    ASSERT_FALSE(model.ok());
    EXPECT_EQ(model.status().code(), StatusCode::kNotFound);
    EXPECT_NE(model.status().message().find("qh_fixture"), std::string::npos);
  }
  {
    // An entry whose subfolder's package.xml names the package (workspace/src layout).
    ScopedEnv env("ROS_PACKAGE_PATH", "/nonexistent:" + FixturePath(""));
    auto model = RobotModel::LoadFromUrdfString(urdf, "/");
    ASSERT_TRUE(model.ok()) << model.status().message();
    EXPECT_TRUE(SameFile(model->link(0).collisions.at(0).mesh_path, tetra));
  }
  {
    // An entry that is the package itself.
    ScopedEnv env("ROS_PACKAGE_PATH", FixturePath("qh_fixture_pkg"));
    auto model = RobotModel::LoadFromUrdfString(urdf, "/");
    ASSERT_TRUE(model.ok()) << model.status().message();
    EXPECT_TRUE(SameFile(model->link(0).collisions.at(0).mesh_path, tetra));
  }
}

TEST(RobotModelTest, FileUriAndBaseDirOfStrings) {
  const std::string tetra = FixturePath("qh_fixture_pkg/meshes/tetra.off");
  const std::string absolute = fs::absolute(tetra).lexically_normal().string();
  auto with_file_uri = RobotModel::LoadFromUrdfString(
      "<robot name='r'><link name='base'><collision><geometry><mesh filename='file://" +
          absolute + "'/></geometry></collision></link></robot>",
      "/");
  ASSERT_TRUE(with_file_uri.ok()) << with_file_uri.status().message();
  EXPECT_EQ(with_file_uri->link(0).collisions.at(0).mesh_path, absolute);

  auto relative = RobotModel::LoadFromUrdfString(
      "<robot name='r'><link name='base'><collision><geometry><mesh filename='meshes/tetra.off'/>"
      "</geometry></collision></link></robot>",
      FixturePath("qh_fixture_pkg"));
  ASSERT_TRUE(relative.ok()) << relative.status().message();
  EXPECT_TRUE(SameFile(relative->link(0).collisions.at(0).mesh_path, tetra));

  LoadFailure(
      "<robot name='r'><link name='base'><collision><geometry><mesh filename='http://x/y.stl'/>"
      "</geometry></collision></link></robot>",
      StatusCode::kInvalidArgument);
}

TEST(RobotModelTest, QuarterTurnsAreExact) {
  // rpy (pi/2, 0, 0) written in decimal: exact zeros and ones, not 1e-16 residues.
  const RobotModel model = RobotModel::LoadFromUrdfFile(FixturePath("box_cylinder.urdf")).value();
  Mat3 expected;
  expected << 1, 0, 0, 0, 0, -1, 0, 1, 0;
  EXPECT_EQ(model.link(0).collisions.at(1).origin.linear(), expected);
  // A general rotation is left alone.
  const RobotModel arm2 = LoadArm2();
  EXPECT_TRUE(arm2.joint(arm2.JointIndex("shoulder")).origin.linear().isApprox(
      Rpy(0.1, -0.2, 0.3), 1e-15));
}

TEST(RobotModelTest, InertialDataInLinkFrameAboutCom) {
  const RobotModel model = LoadArm2();
  const Link& base = model.link(0);
  EXPECT_DOUBLE_EQ(base.mass, 2.0);
  EXPECT_TRUE(base.center_of_mass.isApprox(Vec3(0, 0, 0.01)));
  EXPECT_TRUE(base.inertia.isApprox(Vec3(0.01, 0.02, 0.03).asDiagonal().toDenseMatrix()));
  // The inertial frame of "upper" is turned 90 degrees about z: ixx and iyy swap.
  const Link& upper = model.link(model.LinkIndex("upper"));
  EXPECT_TRUE(upper.center_of_mass.isApprox(Vec3(0.15, 0, 0)));
  const Mat3 expected = Vec3(0.002, 0.001, 0.003).asDiagonal();
  EXPECT_LT((upper.inertia - expected).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_DOUBLE_EQ(model.link(model.LinkIndex("flap2")).mass, 0.0);  // no <inertial>
  EXPECT_NEAR(model.TotalMass(), 2.0 + 0.5 + 0.3 + 0.1 + 0.05, 1e-12);
}

TEST(RobotModelTest, MissingFileIsNotFound) {
  const std::string path = FixturePath("no_such_robot.urdf");
  auto model = RobotModel::LoadFromUrdfFile(path);
  ASSERT_FALSE(model.ok());
  EXPECT_EQ(model.status().code(), StatusCode::kNotFound);
  EXPECT_NE(model.status().message().find(path), std::string::npos) << model.status().message();
}

TEST(RobotModelTest, DirectoryIsIoError) {
  auto model = RobotModel::LoadFromUrdfFile(FixturePath("qh_fixture_pkg"));
  ASSERT_FALSE(model.ok());
  EXPECT_EQ(model.status().code(), StatusCode::kIoError);
}

TEST(RobotModelTest, MalformedXmlNamesFileAndLineAndPrintsNothing) {
  const std::string path = FixturePath("malformed.urdf");
  ::testing::internal::CaptureStderr();
  ::testing::internal::CaptureStdout();
  auto model = RobotModel::LoadFromUrdfFile(path);
  const std::string out = ::testing::internal::GetCapturedStdout();
  const std::string err = ::testing::internal::GetCapturedStderr();
  ASSERT_FALSE(model.ok());
  EXPECT_EQ(model.status().code(), StatusCode::kInvalidArgument);
  const std::string& message = model.status().message();
  EXPECT_EQ(message.rfind(path + ": malformed XML at line ", 0), 0u) << message;
  EXPECT_EQ(message.find('\n'), std::string::npos);
  EXPECT_EQ(out, "");
  EXPECT_EQ(err, "");
}

TEST(RobotModelTest, UnknownMimicSourceNamesFileAndJoints) {
  const std::string path = FixturePath("bad_mimic.urdf");
  auto model = RobotModel::LoadFromUrdfFile(path);
  ASSERT_FALSE(model.ok());
  EXPECT_EQ(model.status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(model.status().message(),
            path + ": joint 'follower' mimics unknown joint 'no_such_joint'");
}

TEST(RobotModelTest, UrdfdomErrorsComeBackAsOneSilentLine) {
  // A joint naming an undefined link: urdfdom rejects it through console_bridge.
  ::testing::internal::CaptureStderr();
  ::testing::internal::CaptureStdout();
  const core::Status status = LoadFailure(
      OneLinkUrdf(RevoluteJoint("j", "base", "ghost")), StatusCode::kInvalidArgument);
  const std::string out = ::testing::internal::GetCapturedStdout();
  const std::string err = ::testing::internal::GetCapturedStderr();
  EXPECT_NE(status.message().find("ghost"), std::string::npos) << status.message();
  EXPECT_EQ(status.message().rfind("URDF string: ", 0), 0u) << status.message();
  EXPECT_EQ(out, "");
  EXPECT_EQ(err, "");

  // A revolute joint without <limit>.
  LoadFailure("<robot name='r'><link name='base'/><link name='a'/><joint name='j' "
              "type='revolute'><parent link='base'/><child link='a'/></joint></robot>",
              StatusCode::kInvalidArgument);
}

TEST(RobotModelTest, ElementsUrdfdomWouldDropAreErrors) {
  // urdfdom logs these and returns a model without the element; we refuse.
  const core::Status bad_size = LoadFailure(
      "<robot name='r'><link name='a'><collision><geometry><box size='1 x 1'/></geometry>"
      "</collision></link></robot>",
      StatusCode::kInvalidArgument);
  EXPECT_NE(bad_size.message().find("collision"), std::string::npos) << bad_size.message();
  LoadFailure("<robot name='r'><link name='a'><inertial><mass value='1'/></inertial></link>"
              "</robot>",
              StatusCode::kInvalidArgument);
}

TEST(RobotModelTest, StructuralErrors) {
  EXPECT_NE(LoadFailure(" \n", StatusCode::kInvalidArgument).message().find("empty"),
            std::string::npos);
  EXPECT_NE(LoadFailure("<robot name='r'><link name='a'>", StatusCode::kInvalidArgument)
                .message()
                .find("malformed XML"),
            std::string::npos);
  EXPECT_NE(LoadFailure("<robt name='r'/>", StatusCode::kInvalidArgument).message().find("robot"),
            std::string::npos);
  // Two parents for one link.
  const std::string two_parents =
      "<robot name='r'><link name='base'/><link name='a'/><link name='b'/>" +
      RevoluteJoint("j1", "base", "a") + RevoluteJoint("j2", "base", "b") +
      RevoluteJoint("j3", "a", "b") + "</robot>";
  EXPECT_NE(LoadFailure(two_parents, StatusCode::kInvalidArgument).message().find("loop"),
            std::string::npos);
  // A loop detached from the root: every link has one parent, a and b are unreachable.
  const std::string detached_loop =
      "<robot name='r'><link name='base'/><link name='a'/><link name='b'/>" +
      RevoluteJoint("j1", "a", "b") + RevoluteJoint("j2", "b", "a") + "</robot>";
  EXPECT_NE(LoadFailure(detached_loop, StatusCode::kInvalidArgument).message().find("loop"),
            std::string::npos);
}

// Lengths no robot has (found by probing: a collision origin 1e300 m away
// reached the mesh check as "self-intersecting"): each refused with its reason.
TEST(RobotModelTest, AbsurdLengthsAreRefused) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"<link name='a'><collision><origin xyz='1e300 0 0'/><geometry><sphere radius='0.1'/></geometry></collision>"
       "</link>",
       "collision origin xyz must be finite and within 1000 m"},
      {"<link name='a'><collision><geometry><sphere radius='1e9'/></geometry></collision></link>",
       "sphere radius must be positive and at most 1000 m"},
      {"<link name='a'><collision><geometry><box size='1e9 1 1'/></geometry></collision></link>",
       "box size must be positive and at most 1000 m"},
      {"<link name='a'><collision><geometry><cylinder radius='0.1' length='1e300'/></geometry></collision></link>",
       "cylinder radius and length must be positive and at most 1000 m"},
      {"<link name='a'/><link name='b'/><joint name='j' type='fixed'><origin xyz='0 0 -5e3'/><parent link='a'/>"
       "<child link='b'/></joint>",
       "joint 'j': origin xyz must be finite and within 1000 m"},
  };
  for (const auto& [body, fragment] : cases) {
    const core::Status status = LoadFailure("<robot name='r'>" + body + "</robot>", StatusCode::kInvalidArgument);
    EXPECT_NE(status.message().find(fragment), std::string::npos) << status.message();
  }
}

TEST(RobotModelTest, UnsupportedJointTypes) {
  for (const std::string type : {"floating", "planar"}) {
    const std::string xml = "<robot name='r'><link name='base'/><link name='a'/><joint name='j' "
                            "type='" + type +
                            "'><parent link='base'/><child link='a'/></joint></robot>";
    const core::Status status = LoadFailure(xml, StatusCode::kInvalidArgument);
    EXPECT_NE(status.message().find("unsupported"), std::string::npos) << status.message();
    EXPECT_NE(status.message().find(type), std::string::npos) << status.message();
  }
}

TEST(RobotModelTest, BadMimics) {
  const std::string links = "<robot name='r'><link name='base'/><link name='a'/><link name='b'/>";
  // Mimic of a fixed joint.
  const std::string of_fixed =
      links + "<joint name='f' type='fixed'><parent link='base'/><child link='a'/></joint>" +
      RevoluteJoint("m", "base", "b", "<mimic joint='f'/>") + "</robot>";
  EXPECT_NE(LoadFailure(of_fixed, StatusCode::kInvalidArgument).message().find("fixed"),
            std::string::npos);
  // Two mimics of each other.
  const std::string loop = links + RevoluteJoint("m1", "base", "a", "<mimic joint='m2'/>") +
                           RevoluteJoint("m2", "base", "b", "<mimic joint='m1'/>") + "</robot>";
  EXPECT_NE(LoadFailure(loop, StatusCode::kInvalidArgument).message().find("loop"),
            std::string::npos);
}

TEST(RobotModelTest, UnknownPackageIsNotFound) {
  ScopedEnv env("ROS_PACKAGE_PATH", "");
  const core::Status status = LoadFailure(
      "<robot name='r'><link name='base'><collision><geometry>"
      "<mesh filename='package://no_such_package_xyz/m.stl'/></geometry></collision></link>"
      "</robot>",
      StatusCode::kNotFound);
  EXPECT_NE(status.message().find("no_such_package_xyz"), std::string::npos);
  EXPECT_NE(status.message().find("link 'base'"), std::string::npos) << status.message();
}

// tinyxml reads no document type definition: with one, the <robot> after it
// was "not found" and an entity bomb looked like a missing element. Refused
// by name; a plain <!DOCTYPE robot> (no definitions) still loads.
TEST(RobotModelTest, DocumentTypeDefinitionsAreRefusedByName) {
  const std::string bomb =
      "<?xml version='1.0'?>\n<!DOCTYPE robot [\n <!ENTITY a 'aaaaaaaaaa'>\n <!ENTITY b '&a;&a;&a;&a;&a;'>\n]>\n" +
      OneLinkUrdf("<link name='&b;'/>");
  auto model = RobotModel::LoadFromUrdfString(bomb, ".");
  ASSERT_FALSE(model.ok());
  EXPECT_EQ(model.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(model.status().message().find("document type definition"), std::string::npos) << model.status().message();
  auto plain = RobotModel::LoadFromUrdfString("<?xml version='1.0'?>\n<!DOCTYPE robot>\n" + OneLinkUrdf(""), ".");
  ASSERT_TRUE(plain.ok()) << plain.status().message();
  EXPECT_EQ(plain->num_links(), 1);
  // Markup quoted in a comment or CDATA, or a "[" inside a quoted system
  // id, is not a definition.
  for (const std::string& harmless :
       {std::string("<?xml version='1.0'?>\n<!-- an old note: <!ENTITY x 'y'> and <!DOCTYPE robot [ ] > -->\n"),
        std::string("<?xml version='1.0'?>\n<!DOCTYPE robot SYSTEM \"robots[1].dtd\">\n")}) {
    auto loaded = RobotModel::LoadFromUrdfString(harmless + OneLinkUrdf(""), ".");
    EXPECT_TRUE(loaded.ok()) << harmless << ": " << loaded.status().message();
  }
  auto after_comment = RobotModel::LoadFromUrdfString(
      "<?xml version='1.0'?>\n<!-- note -->\n<!DOCTYPE robot [ <!ENTITY a 'b'> ]>\n" + OneLinkUrdf(""), ".");
  ASSERT_FALSE(after_comment.ok());
  EXPECT_NE(after_comment.status().message().find("document type definition"), std::string::npos)
      << after_comment.status().message();
  auto unterminated = RobotModel::LoadFromUrdfString("<?xml version='1.0'?>\n<!-- never closed\n" + OneLinkUrdf(""), ".");
  EXPECT_FALSE(unterminated.ok());
}

TEST(RobotModelTest, SingleLinkRobot) {
  auto model = RobotModel::LoadFromUrdfString(OneLinkUrdf(""), ".");
  ASSERT_TRUE(model.ok()) << model.status().message();
  EXPECT_EQ(model->num_links(), 1);
  EXPECT_EQ(model->num_joints(), 0);
  EXPECT_EQ(model->num_actuated(), 0);
  EXPECT_TRUE(model->CollisionLinks().empty());
}

}  // namespace
}  // namespace quadhand::robot
