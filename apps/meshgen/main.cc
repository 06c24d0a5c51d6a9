// quadhand-meshgen: generates the QuadHand reference robot of robot.md: one
// closed binary STL per collision link (in the link's own frame), the URDF
// that ties them together, and primitives.yaml, the exact primitives the
// meshes tessellate, for tools that need exact distances.
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>
#include <system_error>
#include <vector>

#include <CLI/CLI.hpp>

#include "quadhand/core/file_util.h"
#include "quadhand/core/log.h"
#include "quadhand/core/status.h"
#include "quadhand/core/types.h"
#include "quadhand/geometry/mesh_io.h"
#include "quadhand/geometry/primitives.h"
#include "quadhand/geometry/triangle_mesh.h"

namespace quadhand {
namespace {

using geometry::TriangleMesh;

constexpr double kPi = 3.14159265358979323846;
constexpr int kBadInputExitCode = 2;

// One primitive of a link, in the link frame. Its pose is given as position
// and roll-pitch-yaw (URDF convention, R = Rz(yaw) Ry(pitch) Rx(roll)) so that
// primitives.yaml can state it exactly as it was used.
struct PrimitiveSpec {
  enum class Kind { kBox, kCylinder };
  std::string name;
  Kind kind = Kind::kBox;
  Vec3 position = Vec3::Zero();
  Vec3 rpy = Vec3::Zero();
  Vec3 box_size = Vec3::Zero();  // full edge lengths (box)
  double radius = 0.0;           // cylinder, axis = the pose's z axis
  double length = 0.0;
  // A box tessellated in place of this one for the union, where the exact box
  // only touches its neighbour face to face (a degenerate case for boolean
  // operations). It must only add volume that the union already contains.
  std::optional<geometry::Box> union_part;

  Pose pose() const {
    const Mat3 rotation = (Eigen::AngleAxisd(rpy.z(), Vec3::UnitZ()) *
                           Eigen::AngleAxisd(rpy.y(), Vec3::UnitY()) *
                           Eigen::AngleAxisd(rpy.x(), Vec3::UnitX()))
                              .toRotationMatrix();
    return MakePose(position, rotation);
  }
};

struct LinkSpec {
  std::string name;
  double mass = 0.0;
  Vec3 centre_of_mass = Vec3::Zero();
  std::vector<PrimitiveSpec> primitives;
};

PrimitiveSpec BoxSpec(const std::string& name, const Vec3& position, const Vec3& size,
                      double yaw = 0.0) {
  PrimitiveSpec spec;
  spec.name = name;
  spec.kind = PrimitiveSpec::Kind::kBox;
  spec.position = position;
  spec.rpy = Vec3(0.0, 0.0, yaw);
  spec.box_size = size;
  return spec;
}

// Axis-aligned box given by its intervals, as robot.md states most of them.
PrimitiveSpec BoxFromIntervals(const std::string& name, const Vec3& min, const Vec3& max) {
  return BoxSpec(name, 0.5 * (min + max), max - min);
}

PrimitiveSpec CylinderSpec(const std::string& name, const Vec3& position, const Vec3& rpy,
                           double radius, double length) {
  PrimitiveSpec spec;
  spec.name = name;
  spec.kind = PrimitiveSpec::Kind::kCylinder;
  spec.position = position;
  spec.rpy = rpy;
  spec.radius = radius;
  spec.length = length;
  return spec;
}

// The reference robot, transcribed from robot.md.
std::vector<LinkSpec> ReferenceRobot() {
  const Vec3 axis_y_rpy(-kPi / 2.0, 0.0, 0.0);  // turns the cylinder's z axis onto +y
  const double guard = 0.1167;
  std::vector<LinkSpec> links;

  LinkSpec base{"base_link", 1.12, Vec3::Zero(), {}};
  base.primitives.push_back(BoxSpec("plate", Vec3::Zero(), Vec3(0.18, 0.12, 0.05)));
  base.primitives.push_back(
      BoxSpec("arm_bar_plus_45", Vec3::Zero(), Vec3(0.33, 0.025, 0.015), kPi / 4.0));
  base.primitives.push_back(
      BoxSpec("arm_bar_minus_45", Vec3::Zero(), Vec3(0.33, 0.025, 0.015), -kPi / 4.0));
  const struct {
    const char* name;
    double x, y;
  } guards[] = {{"rotor_guard_front_left", guard, guard},
                {"rotor_guard_front_right", guard, -guard},
                {"rotor_guard_rear_left", -guard, guard},
                {"rotor_guard_rear_right", -guard, -guard}};
  for (const auto& g : guards) {
    base.primitives.push_back(
        CylinderSpec(g.name, Vec3(g.x, g.y, 0.025), Vec3::Zero(), 0.065, 0.02));
  }
  links.push_back(base);

  LinkSpec battery{"battery", 0.25, Vec3(-0.085, 0.0, 0.0), {}};
  battery.primitives.push_back(
      BoxFromIntervals("pack", Vec3(-0.15, -0.025, -0.018), Vec3(-0.02, 0.025, 0.018)));
  links.push_back(battery);

  LinkSpec link1{"link1", 0.10, Vec3(0.10, 0.0, 0.0), {}};
  link1.primitives.push_back(
      BoxFromIntervals("beam", Vec3(0.0, -0.015, -0.015), Vec3(0.20, 0.015, 0.015)));
  link1.primitives.push_back(CylinderSpec("hub", Vec3::Zero(), axis_y_rpy, 0.02, 0.05));
  links.push_back(link1);

  LinkSpec link2{"link2", 0.08, Vec3(0.08, 0.0, 0.0), {}};
  link2.primitives.push_back(
      BoxFromIntervals("beam", Vec3(0.0, -0.0125, -0.0125), Vec3(0.16, 0.0125, 0.0125)));
  link2.primitives.push_back(CylinderSpec("hub", Vec3::Zero(), axis_y_rpy, 0.017, 0.04));
  links.push_back(link2);

  LinkSpec link3{"link3", 0.15, Vec3(0.05, 0.0, 0.0), {}};
  link3.primitives.push_back(
      BoxFromIntervals("palm", Vec3(0.0, -0.095, -0.015), Vec3(0.03, 0.095, 0.015)));
  for (const double side : {1.0, -1.0}) {
    const double y_inner = 0.075 * side, y_outer = 0.085 * side;
    PrimitiveSpec finger = BoxFromIntervals(
        side > 0 ? "finger_left" : "finger_right",
        Vec3(0.03, std::min(y_inner, y_outer), -0.01), Vec3(0.11, std::max(y_inner, y_outer), 0.01));
    // The finger starts on the palm's front face; for the union it reaches 1 cm
    // into the palm (which contains that part anyway), so the boolean
    // operation sees a proper overlap instead of two touching faces.
    const Vec3 min(0.02, std::min(y_inner, y_outer), -0.01);
    const Vec3 max(0.11, std::max(y_inner, y_outer), 0.01);
    finger.union_part = geometry::Box{MakePose(0.5 * (min + max), Mat3::Identity()), max - min};
    link3.primitives.push_back(finger);
  }
  links.push_back(link3);
  return links;
}

core::Result<TriangleMesh> LinkMesh(const LinkSpec& link, double tolerance) {
  std::vector<TriangleMesh> parts;
  for (const PrimitiveSpec& primitive : link.primitives) {
    if (primitive.kind == PrimitiveSpec::Kind::kBox) {
      parts.push_back(geometry::TessellateBox(
          primitive.union_part.value_or(geometry::Box{primitive.pose(), primitive.box_size})));
    } else {
      parts.push_back(geometry::TessellateCylinder(
          geometry::Cylinder{primitive.pose(), primitive.radius, primitive.length}, tolerance));
    }
  }
  if (parts.size() == 1) return parts.front();
  auto merged = geometry::UnionOfClosedMeshes(parts);
  if (!merged.ok()) return merged.status().WithPrefix("link " + link.name);
  return merged;
}

// Volume, centroid and inertia tensor (about the centroid, unit density) of a
// closed outward mesh, from the divergence theorem (D. Eberly, "Polyhedral
// Mass Properties").
struct MassProperties {
  double volume = 0.0;
  Vec3 centroid = Vec3::Zero();
  Mat3 inertia = Mat3::Zero();
};

MassProperties ComputeMassProperties(const TriangleMesh& mesh) {
  // Integrals of 1, x, y, z, x^2, y^2, z^2, xy, yz, zx over the solid,
  // accumulated about the bounding-box centre to limit cancellation.
  const geometry::AxisAlignedBox box = geometry::BoundingBox(mesh);
  const Vec3 reference = 0.5 * (box.min + box.max);
  double integral[10] = {};
  auto subexpressions = [](double w0, double w1, double w2, double* f1, double* f2, double* f3,
                           double* g0, double* g1, double* g2) {
    const double temp0 = w0 + w1;
    *f1 = temp0 + w2;
    const double temp1 = w0 * w0;
    const double temp2 = temp1 + w1 * temp0;
    *f2 = temp2 + w2 * *f1;
    *f3 = w0 * temp1 + w1 * temp2 + w2 * *f2;
    *g0 = *f2 + w0 * (*f1 + w0);
    *g1 = *f2 + w1 * (*f1 + w1);
    *g2 = *f2 + w2 * (*f1 + w2);
  };
  for (const Eigen::Vector3i& t : mesh.triangles) {
    const Vec3 p0 = mesh.vertices[t[0]] - reference;
    const Vec3 p1 = mesh.vertices[t[1]] - reference;
    const Vec3 p2 = mesh.vertices[t[2]] - reference;
    const Vec3 d = (p1 - p0).cross(p2 - p0);
    double f1[3], f2[3], f3[3], g0[3], g1[3], g2[3];
    for (int axis = 0; axis < 3; ++axis) {
      subexpressions(p0[axis], p1[axis], p2[axis], &f1[axis], &f2[axis], &f3[axis], &g0[axis],
                     &g1[axis], &g2[axis]);
    }
    integral[0] += d.x() * f1[0];
    for (int axis = 0; axis < 3; ++axis) {
      integral[1 + axis] += d[axis] * f2[axis];
      integral[4 + axis] += d[axis] * f3[axis];
    }
    integral[7] += d.x() * (p0.y() * g0[0] + p1.y() * g1[0] + p2.y() * g2[0]);
    integral[8] += d.y() * (p0.z() * g0[1] + p1.z() * g1[1] + p2.z() * g2[1]);
    integral[9] += d.z() * (p0.x() * g0[2] + p1.x() * g1[2] + p2.x() * g2[2]);
  }
  integral[0] /= 6.0;
  for (int i = 1; i <= 3; ++i) integral[i] /= 24.0;
  for (int i = 4; i <= 6; ++i) integral[i] /= 60.0;
  for (int i = 7; i <= 9; ++i) integral[i] /= 120.0;

  MassProperties properties;
  const double v = integral[0];
  properties.volume = v;
  const Vec3 c = Vec3(integral[1], integral[2], integral[3]) / v;  // relative to `reference`
  properties.centroid = reference + c;
  Mat3& inertia = properties.inertia;
  inertia(0, 0) = integral[5] + integral[6] - v * (c.y() * c.y() + c.z() * c.z());
  inertia(1, 1) = integral[4] + integral[6] - v * (c.z() * c.z() + c.x() * c.x());
  inertia(2, 2) = integral[4] + integral[5] - v * (c.x() * c.x() + c.y() * c.y());
  inertia(0, 1) = inertia(1, 0) = -(integral[7] - v * c.x() * c.y());
  inertia(1, 2) = inertia(2, 1) = -(integral[8] - v * c.y() * c.z());
  inertia(0, 2) = inertia(2, 0) = -(integral[9] - v * c.z() * c.x());
  return properties;
}

// Shortest text that reads back as the same double; tiny round-off noise
// (|x| < 1e-15, e.g. products of inertia of symmetric parts) is written as 0.
std::string Number(double value) {
  if (std::abs(value) < 1e-15) value = 0.0;
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  std::string text(buffer, result.ptr);
  // YAML 1.1 readers (PyYAML) take "1e-04" for a string: write "1.0e-04".
  const size_t exponent = text.find('e');
  if (exponent != std::string::npos && text.find('.') == std::string::npos) {
    text.insert(exponent, ".0");
  }
  return text;
}

std::string Triple(const Vec3& v, const char* separator) {
  return Number(v.x()) + separator + Number(v.y()) + separator + Number(v.z());
}

std::string MeshFileName(const LinkSpec& link) { return link.name + ".stl"; }

std::string LinkXml(const LinkSpec& link, const MassProperties& properties) {
  // Inertia of the mesh filled with uniform density, scaled to the link's mass.
  const Mat3 inertia = properties.inertia * (link.mass / properties.volume);
  std::string xml = "  <link name=\"" + link.name + "\">\n";
  xml += "    <inertial>\n";
  xml += "      <origin xyz=\"" + Triple(link.centre_of_mass, " ") + "\" rpy=\"0 0 0\"/>\n";
  xml += "      <mass value=\"" + Number(link.mass) + "\"/>\n";
  xml += "      <inertia ixx=\"" + Number(inertia(0, 0)) + "\" ixy=\"" + Number(inertia(0, 1)) +
         "\" ixz=\"" + Number(inertia(0, 2)) + "\" iyy=\"" + Number(inertia(1, 1)) +
         "\" iyz=\"" + Number(inertia(1, 2)) + "\" izz=\"" + Number(inertia(2, 2)) + "\"/>\n";
  xml += "    </inertial>\n";
  for (const char* element : {"visual", "collision"}) {
    xml += std::string("    <") + element + ">\n";
    xml += "      <origin xyz=\"0 0 0\" rpy=\"0 0 0\"/>\n";
    xml += "      <geometry>\n";
    xml += "        <mesh filename=\"" + MeshFileName(link) + "\"/>\n";
    xml += "      </geometry>\n";
    if (std::string(element) == "visual") xml += "      <material name=\"grey\"/>\n";
    xml += std::string("    </") + element + ">\n";
  }
  xml += "  </link>\n";
  return xml;
}

struct JointSpec {
  std::string name, type, parent, child;
  Vec3 origin = Vec3::Zero();
  Vec3 axis = Vec3::Zero();
  double lower = 0.0, upper = 0.0, velocity = 0.0;
  std::string mimic;  // joint this one follows with multiplier -1, or empty
};

std::string JointXml(const JointSpec& joint) {
  // robot.md gives no torques; 5 N m is a plausible bound for small servos.
  constexpr double kEffort = 5.0;
  std::string xml = "  <joint name=\"" + joint.name + "\" type=\"" + joint.type + "\">\n";
  xml += "    <parent link=\"" + joint.parent + "\"/>\n";
  xml += "    <child link=\"" + joint.child + "\"/>\n";
  xml += "    <origin xyz=\"" + Triple(joint.origin, " ") + "\" rpy=\"0 0 0\"/>\n";
  if (joint.type == "revolute") {
    xml += "    <axis xyz=\"" + Triple(joint.axis, " ") + "\"/>\n";
    xml += "    <limit lower=\"" + Number(joint.lower) + "\" upper=\"" + Number(joint.upper) +
           "\" effort=\"" + Number(kEffort) + "\" velocity=\"" + Number(joint.velocity) + "\"/>\n";
  }
  if (!joint.mimic.empty()) {
    xml += "    <mimic joint=\"" + joint.mimic + "\" multiplier=\"-1\" offset=\"0\"/>\n";
  }
  xml += "  </joint>\n";
  return xml;
}

std::string Urdf(const std::vector<LinkSpec>& links,
                 const std::vector<MassProperties>& properties) {
  std::string xml = "<?xml version=\"1.0\"?>\n";
  xml +=
      "<!-- QuadHand reference robot (robot.md), generated by quadhand-meshgen\n"
      "     (scripts/make_reference_robot.sh): edit the generator, not this file.\n"
      "     Units: metres, radians, kilograms. Mesh files are relative to this file and\n"
      "     expressed in their link's frame.\n"
      "     Inertials: mass and centre of mass as robot.md specifies them. The inertia\n"
      "     tensor is that of the link's collision mesh filled with uniform density,\n"
      "     scaled to the link's mass, taken about the mesh's own centroid with the\n"
      "     link frame's axes (robot.md gives no inertia; the mesh centroid can differ\n"
      "     slightly from the specified centre of mass). -->\n";
  xml += "<robot name=\"quadhand\">\n";
  xml += "  <material name=\"grey\">\n    <color rgba=\"0.6 0.6 0.6 1\"/>\n  </material>\n";
  for (size_t i = 0; i < links.size(); ++i) xml += LinkXml(links[i], properties[i]);
  xml += "  <!-- The end-effector frame: x is the approach direction, between the fingertips. -->\n";
  xml += "  <link name=\"tool\"/>\n";
  const Vec3 pitch_axis = Vec3::UnitY(), roll_axis = Vec3::UnitX();
  const std::vector<JointSpec> joints = {
      {"joint1", "revolute", "base_link", "link1", Vec3(0.04, 0.0, -0.045), pitch_axis, 0.0, 1.57,
       2.0, ""},
      {"joint2", "revolute", "link1", "link2", Vec3(0.20, 0.0, 0.0), pitch_axis, -1.5, 1.5, 2.0,
       ""},
      {"joint3", "revolute", "link2", "link3", Vec3(0.16, 0.0, 0.0), roll_axis, -3.14, 3.14, 3.0,
       ""},
      {"battery_joint", "revolute", "base_link", "battery", Vec3(-0.06, 0.0, -0.045), pitch_axis,
       -1.57, 0.0, 2.0, "joint1"},
      {"tool_joint", "fixed", "link3", "tool", Vec3(0.11, 0.0, 0.0), Vec3::Zero(), 0.0, 0.0, 0.0,
       ""},
  };
  for (const JointSpec& joint : joints) {
    if (joint.name == "battery_joint") {
      xml +=
          "  <!-- Passive CoG compensation: the battery turns opposite to joint1, so it hangs\n"
          "       down as the arm does. -->\n";
    }
    xml += JointXml(joint);
  }
  xml += "</robot>\n";
  return xml;
}

std::string PrimitivesYaml(const std::vector<LinkSpec>& links, double tolerance) {
  std::string yaml =
      "# Exact primitives of the QuadHand reference robot (robot.md), generated by\n"
      "# quadhand-meshgen together with the meshes that tessellate them.\n"
      "# Each link's solid is the union of its primitives, in the link's own frame.\n"
      "# Outside a link, its exact distance is the minimum over its primitives of the\n"
      "# exact primitive distance (inside, that minimum is only an upper bound).\n"
      "# Units: metres, radians. position: centre of the primitive; rpy: roll, pitch,\n"
      "# yaw of its axes (URDF convention, R = Rz(yaw) Ry(pitch) Rx(roll)).\n"
      "# box: size = full edge lengths along its axes.\n"
      "# cylinder: axis = its z axis (also written out as `axis`), centred on its\n"
      "# position, radius and full length.\n"
      "# mesh_tolerance: largest distance of a mesh's curved surfaces from the primitives\n"
      "# (vertices lie on them, chords inside).\n";
  yaml += "mesh_tolerance: " + Number(tolerance) + "\n";
  yaml += "links:\n";
  for (const LinkSpec& link : links) {
    yaml += "  " + link.name + ":\n";
    yaml += "    mesh: " + MeshFileName(link) + "\n";
    yaml += "    primitives:\n";
    for (const PrimitiveSpec& p : link.primitives) {
      yaml += "      - name: " + p.name + "\n";
      yaml += std::string("        type: ") +
              (p.kind == PrimitiveSpec::Kind::kBox ? "box" : "cylinder") + "\n";
      yaml += "        position: [" + Triple(p.position, ", ") + "]\n";
      yaml += "        rpy: [" + Triple(p.rpy, ", ") + "]\n";
      if (p.kind == PrimitiveSpec::Kind::kBox) {
        yaml += "        size: [" + Triple(p.box_size, ", ") + "]\n";
      } else {
        yaml += "        axis: [" + Triple(p.pose().linear().col(2), ", ") + "]\n";
        yaml += "        radius: " + Number(p.radius) + "\n";
        yaml += "        length: " + Number(p.length) + "\n";
      }
    }
  }
  return yaml;
}

int Fail(const std::string& message) {
  core::PrintError("quadhand-meshgen", message);
  return kBadInputExitCode;
}

int Run(const std::string& out_dir, double tolerance, bool quiet) {
  std::error_code error;
  std::filesystem::create_directories(out_dir, error);
  if (error || !std::filesystem::is_directory(out_dir)) {
    return Fail("cannot create output directory " + out_dir +
                (error ? ": " + error.message() : std::string()));
  }
  const std::vector<LinkSpec> links = ReferenceRobot();
  std::vector<TriangleMesh> meshes;
  std::vector<MassProperties> properties;
  // Build and check everything before writing anything.
  for (const LinkSpec& link : links) {
    auto mesh = LinkMesh(link, tolerance);
    if (!mesh.ok()) return Fail(mesh.status().message());
    const geometry::MeshCheck check = geometry::CheckMesh(*mesh);
    if (!check.bounds_volume || !check.outward) {
      return Fail("generated mesh of link " + link.name + " is invalid: " + check.problem);
    }
    properties.push_back(ComputeMassProperties(*mesh));
    meshes.push_back(std::move(mesh).value());
  }
  for (size_t i = 0; i < links.size(); ++i) {
    const std::string path = core::ResolvePath(out_dir, MeshFileName(links[i]));
    const core::Status status = geometry::WriteMesh(path, meshes[i]);
    if (!status.ok()) return Fail(status.message());
  }
  for (const auto& [name, contents] :
       {std::pair<std::string, std::string>{"quadhand.urdf", Urdf(links, properties)},
        {"primitives.yaml", PrimitivesYaml(links, tolerance)}}) {
    const core::Status status =
        core::WriteFileAtomically(core::ResolvePath(out_dir, name), contents);
    if (!status.ok()) return Fail(status.message());
  }
  if (!quiet) {
    std::printf("%-10s %9s %13s  %-28s %-28s\n", "link", "triangles", "volume [cm3]",
                "bbox min [m]", "bbox max [m]");
    for (size_t i = 0; i < links.size(); ++i) {
      const geometry::AxisAlignedBox box = geometry::BoundingBox(meshes[i]);
      std::printf("%-10s %9d %13.4f  (%8.5f %8.5f %8.5f) (%8.5f %8.5f %8.5f)\n",
                  links[i].name.c_str(), meshes[i].num_triangles(), properties[i].volume * 1e6,
                  box.min.x(), box.min.y(), box.min.z(), box.max.x(), box.max.y(), box.max.z());
    }
    std::printf("wrote %zu meshes, quadhand.urdf and primitives.yaml to %s\n", links.size(),
                out_dir.c_str());
  }
  return 0;
}

}  // namespace
}  // namespace quadhand

int main(int argc, char** argv) {
  CLI::App app{
      "Generates the QuadHand reference robot (robot.md): one closed binary STL per collision "
      "link, quadhand.urdf and primitives.yaml (the exact primitives the meshes tessellate)."};
  std::string out_dir;
  double tolerance = 1e-4;
  bool quiet = false;
  app.add_option("--out", out_dir, "Output directory (created if missing)")->required();
  app.add_option("--tolerance", tolerance,
                 "Largest distance of curved mesh surfaces from the true primitives, metres, in [1e-6, 1e-3]")
      ->capture_default_str();
  app.add_flag("--quiet", quiet, "Print nothing on success");
  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& e) {  // --help
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    return quadhand::Fail(std::string(e.what()) + " (see --help)");
  }
  // Below a micrometre the curved links need millions of triangles (minutes
  // and gigabytes for nothing a planner can use).
  if (!(tolerance >= 1e-6 && tolerance <= 1e-3)) {
    char given[32];
    std::snprintf(given, sizeof(given), "%g", tolerance);
    return quadhand::Fail(std::string("--tolerance must be in [1e-06, 0.001] metres, got ") + given);
  }
  return quadhand::Run(out_dir, tolerance, quiet);
}
