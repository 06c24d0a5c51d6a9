// quadhand-sdf-accuracy: how far interpolated link SDFs are from the exact
// distance to the true geometry (untessellated primitives), for points outside
// the geometry up to --max-distance away, at several grid resolutions.
// Prints a Markdown table (docs/sdf_accuracy.md was made with it).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <yaml-cpp/yaml.h>

#include "quadhand/geometry/mesh_to_sdf.h"
#include "quadhand/geometry/primitives.h"
#include "quadhand/robot/link_meshes.h"
#include "quadhand/robot/robot_model.h"

namespace quadhand {
namespace {

using ExactDistance = std::function<double(const Vec3&)>;

struct Shape {
  std::string name;
  geometry::TriangleMesh mesh;  // what the SDF is built from
  ExactDistance exact;          // exact signed distance to the true solid (outside: exact)
};

Mat3 RotationFromRpy(const Vec3& rpy) {
  return (Eigen::AngleAxisd(rpy.z(), Vec3::UnitZ()) * Eigen::AngleAxisd(rpy.y(), Vec3::UnitY()) *
          Eigen::AngleAxisd(rpy.x(), Vec3::UnitX()))
      .toRotationMatrix();
}

Vec3 ReadVec3(const YAML::Node& node) { return Vec3(node[0].as<double>(), node[1].as<double>(), node[2].as<double>()); }

// Exact distance to the union of a link's primitives (primitives.yaml).
ExactDistance UnionDistance(const YAML::Node& primitives) {
  std::vector<geometry::Box> boxes;
  std::vector<geometry::Cylinder> cylinders;
  std::vector<geometry::Sphere> spheres;
  for (const YAML::Node& p : primitives) {
    const std::string type = p["type"].as<std::string>();
    const Vec3 position = ReadVec3(p["position"]);
    const Pose pose = MakePose(position, RotationFromRpy(p["rpy"] ? ReadVec3(p["rpy"]) : Vec3::Zero()));
    if (type == "box") {
      boxes.push_back({pose, ReadVec3(p["size"])});
    } else if (type == "cylinder") {
      cylinders.push_back({pose, p["radius"].as<double>(), p["length"].as<double>()});
    } else if (type == "sphere") {
      spheres.push_back({position, p["radius"].as<double>()});
    } else {
      throw std::runtime_error("unknown primitive type " + type);
    }
  }
  return [=](const Vec3& q) {
    double d = 1e300;
    for (const auto& b : boxes) d = std::min(d, geometry::SignedDistance(b, q));
    for (const auto& c : cylinders) d = std::min(d, geometry::SignedDistance(c, q));
    for (const auto& s : spheres) d = std::min(d, geometry::SignedDistance(s, q));
    return d;
  };
}

std::vector<Shape> TestPrimitives(double tolerance) {
  // Rotated so that no face or axis lines up with the grid.
  const Pose tilted = MakePose(Vec3(0.003, -0.002, 0.001), RotationFromRpy(Vec3(0.3, -0.5, 0.7)));
  const geometry::Box box{tilted, Vec3(0.12, 0.08, 0.05)};
  const geometry::Cylinder cylinder{tilted, 0.03, 0.10};
  const geometry::Sphere sphere{Vec3(0.001, 0.002, -0.003), 0.05};
  return {
      {"box 0.12x0.08x0.05", geometry::TessellateBox(box), [box](const Vec3& q) { return geometry::SignedDistance(box, q); }},
      {"cylinder r0.03 l0.10", geometry::TessellateCylinder(cylinder, tolerance),
       [cylinder](const Vec3& q) { return geometry::SignedDistance(cylinder, q); }},
      {"sphere r0.05", geometry::TessellateSphere(sphere, tolerance),
       [sphere](const Vec3& q) { return geometry::SignedDistance(sphere, q); }},
  };
}

struct ErrorStats {
  // max_over: largest amount by which the SDF says "farther" than the truth
  // (the unsafe direction); max_under: "closer" (conservative).
  double max_error = 0, max_over = 0, max_under = 0, sum_squared = 0, max_error_far = 0;
  long count = 0;
};

// Points outside the solid with exact distance in (0, max_distance]: half
// uniform over the grid, half within 5 mm of the surface (where edges make
// the interpolation error largest).
ErrorStats Measure(const Shape& shape, const geometry::SdfGrid& grid, double max_distance, int samples,
                   unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const Vec3 lo = grid.info().origin, hi = grid.info().GridMax();
  std::vector<double> areas;
  double total_area = 0;
  for (const auto& t : shape.mesh.triangles) {
    const Vec3& a = shape.mesh.vertices[t[0]];
    total_area += 0.5 * (shape.mesh.vertices[t[1]] - a).cross(shape.mesh.vertices[t[2]] - a).norm();
    areas.push_back(total_area);
  }
  ErrorStats stats;
  long attempts = 0;
  while (stats.count < samples && attempts < 50L * samples) {
    ++attempts;
    Vec3 p;
    if (attempts % 2 == 0) {
      p = lo + (hi - lo).cwiseProduct(Vec3(unit(rng), unit(rng), unit(rng)));
    } else {
      const auto it = std::lower_bound(areas.begin(), areas.end(), unit(rng) * total_area);
      const auto& t = shape.mesh.triangles[std::min<size_t>(it - areas.begin(), areas.size() - 1)];
      double u = unit(rng), v = unit(rng);
      if (u + v > 1) u = 1 - u, v = 1 - v;
      const Vec3& a = shape.mesh.vertices[t[0]];
      const Vec3 on_surface = a + u * (shape.mesh.vertices[t[1]] - a) + v * (shape.mesh.vertices[t[2]] - a);
      Vec3 direction(unit(rng) - 0.5, unit(rng) - 0.5, unit(rng) - 0.5);
      p = on_surface + direction.normalized() * 0.005 * unit(rng);
    }
    const double exact = shape.exact(p);
    if (!(exact > 0.0 && exact <= max_distance)) continue;
    double d = 0;
    grid.Evaluate(p, &d, nullptr);
    const double error = std::abs(d - exact);
    stats.max_error = std::max(stats.max_error, error);
    stats.max_over = std::max(stats.max_over, d - exact);
    stats.max_under = std::max(stats.max_under, exact - d);
    if (exact >= 0.02) stats.max_error_far = std::max(stats.max_error_far, error);
    stats.sum_squared += error * error;
    ++stats.count;
  }
  return stats;
}

}  // namespace
}  // namespace quadhand

int main(int argc, char** argv) {
  using namespace quadhand;
  CLI::App app{"quadhand-sdf-accuracy: interpolated link-SDF error against exact distances"};
  std::string urdf = std::string(QUADHAND_SOURCE_DIR) + "/meshes/quadhand/quadhand.urdf";
  std::string primitives_file = std::string(QUADHAND_SOURCE_DIR) + "/meshes/quadhand/primitives.yaml";
  std::vector<double> resolutions = {0.004, 0.003, 0.002, 0.0015};
  int samples = 200000;
  double max_distance = 0.08, padding = 0.08;
  bool robot_only = false, primitives_only = false;
  app.add_option("--urdf", urdf, "Robot URDF")->capture_default_str();
  app.add_option("--primitives", primitives_file, "Exact primitives of the robot's links")->capture_default_str();
  app.add_option("--resolutions", resolutions, "Grid resolutions, metres")->delimiter(',');
  app.add_option("--samples", samples, "Points per shape and resolution")->capture_default_str();
  app.add_option("--max-distance", max_distance, "Largest distance from the surface tested")->capture_default_str();
  app.add_option("--padding", padding, "SDF padding")->capture_default_str();
  app.add_flag("--robot-only", robot_only, "Only the robot's links");
  app.add_flag("--primitives-only", primitives_only, "Only the test primitives");
  CLI11_PARSE(app, argc, argv);

  std::vector<Shape> shapes;
  if (!robot_only) shapes = TestPrimitives(robot::kPrimitiveTessellationTolerance);
  if (!primitives_only) {
    auto model = robot::RobotModel::LoadFromUrdfFile(urdf);
    if (!model.ok()) {
      std::fprintf(stderr, "error: %s\n", model.status().message().c_str());
      return 2;
    }
    const YAML::Node links = YAML::LoadFile(primitives_file)["links"];
    for (int link : model->CollisionLinks()) {
      const std::string& name = model->link(link).name;
      auto mesh = robot::LinkCollisionMesh(*model, link);
      if (!mesh.ok() || !links[name]) {
        std::fprintf(stderr, "error: link %s: no mesh or no primitives\n", name.c_str());
        return 2;
      }
      shapes.push_back({"quadhand " + name, std::move(*mesh), UnionDistance(links[name]["primitives"])});
    }
  }

  std::printf("| geometry | resolution (mm) | max error (mm) | max over (mm) | max under (mm) | RMS error (mm) | max error at d >= 20 mm (mm) | nodes | memory (MB) | generation (s) |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|\n");
  for (double resolution : resolutions) {
    for (const Shape& shape : shapes) {
      geometry::SdfGenerationOptions options;
      options.resolution = resolution;
      options.padding = padding;
      const auto start = std::chrono::steady_clock::now();
      auto grid = geometry::GenerateSdf(shape.mesh, "shape", "accuracy", options);
      const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      if (!grid.ok()) {
        std::fprintf(stderr, "error: %s: %s\n", shape.name.c_str(), grid.status().message().c_str());
        return 2;
      }
      const ErrorStats stats = Measure(shape, *grid, max_distance, samples, 17);
      std::printf("| %s | %.1f | %.3f | %.3f | %.3f | %.3f | %.4f | %ld | %.1f | %.1f |\n", shape.name.c_str(),
                  resolution * 1e3, stats.max_error * 1e3, stats.max_over * 1e3, stats.max_under * 1e3, std::sqrt(stats.sum_squared / std::max(1L, stats.count)) * 1e3,
                  stats.max_error_far * 1e3, grid->info().NumNodes(), grid->MemoryBytes() / 1e6, seconds);
      std::fflush(stdout);
    }
  }
  return 0;
}
