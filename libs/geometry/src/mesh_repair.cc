// Mesh intake (mesh_repair.h). Combinatorial work only (hashing, union-find,
// a breadth-first walk); the final verdict on each shell is CheckMesh's
// (CGAL, mesh_io.cc), so a shell is accepted by the same test as before.
#include "quadhand/geometry/mesh_repair.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <numeric>
#include <queue>
#include <unordered_map>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include "quadhand/core/text.h"
#include "quadhand/geometry/mesh_io.h"

namespace quadhand::geometry {
namespace {

using core::Format;
using Face = std::array<int, 3>;

std::string Plural(long n, const char* one, const char* many) { return std::to_string(n) + " " + (n == 1 ? one : many); }

std::string Point(const Vec3& p) { return Format("(%.6g, %.6g, %.6g)", p.x(), p.y(), p.z()); }

// Each vertex mapped to the first vertex within `tolerance` of it (grid
// cells of the tolerance's size, the 27 around each vertex searched).
std::vector<int> MergeVertices(const std::vector<Vec3>& vertices, double tolerance, long* merged) {
  struct CellHash {
    size_t operator()(const std::array<int64_t, 3>& c) const {
      return static_cast<size_t>(c[0] * 73856093LL ^ c[1] * 19349663LL ^ c[2] * 83492791LL);
    }
  };
  std::unordered_map<std::array<int64_t, 3>, std::vector<int>, CellHash> cells;
  cells.reserve(vertices.size());
  std::vector<int> representative(vertices.size());
  auto cell_of = [tolerance](const Vec3& v) {
    return std::array<int64_t, 3>{static_cast<int64_t>(std::floor(v.x() / tolerance)),
                                  static_cast<int64_t>(std::floor(v.y() / tolerance)),
                                  static_cast<int64_t>(std::floor(v.z() / tolerance))};
  };
  for (size_t i = 0; i < vertices.size(); ++i) {
    const std::array<int64_t, 3> c = cell_of(vertices[i]);
    int found = -1;
    for (int dx = -1; dx <= 1 && found < 0; ++dx) {
      for (int dy = -1; dy <= 1 && found < 0; ++dy) {
        for (int dz = -1; dz <= 1 && found < 0; ++dz) {
          auto it = cells.find({c[0] + dx, c[1] + dy, c[2] + dz});
          if (it == cells.end()) continue;
          for (int r : it->second) {
            if ((vertices[r] - vertices[i]).norm() <= tolerance) {
              found = r;
              break;
            }
          }
        }
      }
    }
    if (found >= 0) {
      representative[i] = found;
      ++*merged;
    } else {
      representative[i] = static_cast<int>(i);
      cells[c].push_back(static_cast<int>(i));
    }
  }
  return representative;
}

uint64_t EdgeKey(int a, int b) {
  const auto lo = static_cast<uint64_t>(std::min(a, b)), hi = static_cast<uint64_t>(std::max(a, b));
  return lo << 32 | hi;
}

// Whether face f traverses the edge a -> b (in its own cyclic order).
bool Traverses(const Face& f, int a, int b) {
  for (int k = 0; k < 3; ++k) {
    if (f[k] == a && f[(k + 1) % 3] == b) return true;
  }
  return false;
}

struct UnionFind {
  std::vector<int> parent;
  explicit UnionFind(size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0); }
  int Find(int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  }
  void Join(int a, int b) { parent[Find(a)] = Find(b); }
};

// The border loops' description: count, and for the largest few their edge
// count, centre and size.
std::string DescribeHoles(const std::vector<std::pair<int, int>>& border, const std::vector<Vec3>& vertices) {
  // Loops as connected groups of border edges.
  std::unordered_map<int, int> index;
  for (const auto& [a, b] : border) {
    index.emplace(a, static_cast<int>(index.size()));
    index.emplace(b, static_cast<int>(index.size()));
  }
  UnionFind groups(index.size());
  for (const auto& [a, b] : border) groups.Join(index[a], index[b]);
  std::map<int, std::vector<std::pair<int, int>>> loops;
  for (const auto& e : border) loops[groups.Find(index[e.first])].push_back(e);
  std::vector<std::vector<std::pair<int, int>>> sorted;
  for (auto& [root, edges] : loops) sorted.push_back(std::move(edges));
  std::sort(sorted.begin(), sorted.end(), [](const auto& a, const auto& b) { return a.size() > b.size(); });
  std::string text = Format("not closed: %zu hole%s (", sorted.size(), sorted.size() == 1 ? "" : "s");
  for (size_t i = 0; i < sorted.size() && i < 3; ++i) {
    AxisAlignedBox box;
    Vec3 sum = Vec3::Zero();
    for (const auto& [a, b] : sorted[i]) {
      for (int v : {a, b}) {
        box.min = box.min.cwiseMin(vertices[v]);
        box.max = box.max.cwiseMax(vertices[v]);
      }
      sum += vertices[a] + vertices[b];
    }
    text += (i ? "; " : "") + Format("a border of %zu edges around ", sorted[i].size()) +
            Point(sum / (2.0 * sorted[i].size())) + Format(", %.3g m across", box.size().norm());
  }
  if (sorted.size() > 3) text += "; ...";
  return text + ")";
}

}  // namespace

bool MeshRepairOptions::IsValid(std::string* why) const {
  if (!(std::isfinite(tolerance) && tolerance > 0.0 && tolerance <= 1e-3)) {
    if (why != nullptr) *why = Format("the repair tolerance %g m must be in (0, 0.001] m", tolerance);
    return false;
  }
  if (!(std::isfinite(metres_per_unit) && metres_per_unit > 0.0)) {
    if (why != nullptr) *why = Format("the mesh's scale %g m per unit must be positive", metres_per_unit);
    return false;
  }
  return true;
}

core::Status CheckRepairTolerance(double tolerance, double resolution) {
  MeshRepairOptions options;
  options.tolerance = tolerance;
  if (std::string why; !options.IsValid(&why)) return core::Status::InvalidArgument(why);
  if (!(tolerance <= resolution)) {
    return core::Status::InvalidArgument(Format("the repair tolerance %g m is larger than the SDF resolution %g m",
                                                tolerance, resolution));
  }
  return core::Status::Ok();
}

std::vector<std::string> MeshRepairReport::Lines() const {
  std::vector<std::string> lines;
  if (merged_vertices > 0) lines.push_back("merged " + Plural(merged_vertices, "vertex", "vertices") + " into a neighbour within the tolerance");
  if (degenerate_faces > 0) lines.push_back("removed " + Plural(degenerate_faces, "degenerate face", "degenerate faces") + " (two corners at one vertex)");
  if (duplicate_faces > 0) lines.push_back("removed " + Plural(duplicate_faces, "duplicate face", "duplicate faces"));
  if (soup_points_merged > 0) {
    lines.push_back("CGAL's polygon soup repair merged " + Plural(soup_points_merged, "duplicate point", "duplicate points"));
  }
  if (soup_faces_removed > 0) {
    lines.push_back("CGAL's polygon soup repair removed " +
                    Plural(soup_faces_removed, "duplicate or degenerate face", "duplicate or degenerate faces"));
  }
  if (reversed_duplicate_faces > 0) {
    lines.push_back("removed " + Plural(reversed_duplicate_faces, "reversed duplicate face", "reversed duplicate faces") +
                    " (a face of the surface written again, reversed)");
  }
  if (reversed_duplicate_pairs > 0) {
    lines.push_back("removed " + Plural(reversed_duplicate_pairs, "pair", "pairs") +
                    " of reversed duplicate faces (a face and its reversed copy: a zero-volume fin)");
  }
  if (flipped_faces > 0) lines.push_back("turned " + Plural(flipped_faces, "face", "faces") + " to agree with their neighbours");
  if (outward_shells > 0) lines.push_back("turned " + Plural(outward_shells, "shell", "shells") + " inside out to face outward");
  if (shells > 1 && !lines.empty()) lines.push_back("kept " + std::to_string(shells) + " closed shells (their union is the solid)");
  return lines;
}

core::Result<RepairedMesh> RepairMesh(const TriangleMesh& mesh, const MeshRepairOptions& options) {
  if (std::string why; !options.IsValid(&why)) return core::Status::InvalidArgument(why);
  const int num_vertices = static_cast<int>(mesh.vertices.size());
  for (size_t v = 0; v < mesh.vertices.size(); ++v) {
    if (!mesh.vertices[v].allFinite()) {
      return core::Status::InvalidArgument("vertex " + std::to_string(v) + " is not finite (NaN or infinity)");
    }
  }
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    if ((mesh.triangles[t].array() < 0).any() || (mesh.triangles[t].array() >= num_vertices).any()) {
      return core::Status::InvalidArgument("triangle " + std::to_string(t) + " names a vertex the mesh does not have");
    }
  }
  if (mesh.triangles.empty()) return core::Status::InvalidArgument("the mesh has no faces");

  RepairedMesh result;
  MeshRepairReport& report = result.report;
  const std::vector<int> same =
      MergeVertices(mesh.vertices, options.tolerance / options.metres_per_unit, &report.merged_vertices);

  // Faces on the merged vertices; degenerate ones dropped.
  std::vector<Face> faces;
  faces.reserve(mesh.triangles.size());
  for (const Eigen::Vector3i& t : mesh.triangles) {
    const Face f{same[t[0]], same[t[1]], same[t[2]]};
    if (f[0] == f[1] || f[1] == f[2] || f[0] == f[2]) {
      ++report.degenerate_faces;
      continue;
    }
    faces.push_back(f);
  }
  if (faces.empty()) {
    return core::Status::InvalidArgument(Format("every one of its %zu faces is degenerate (no area at a tolerance of %g m)",
                                                mesh.triangles.size(), options.tolerance));
  }
  // Faces whose three distinct corners lie on one line (exact predicate):
  // a mesh of nothing else has no surface at all.
  {
    using Point = CGAL::Exact_predicates_inexact_constructions_kernel::Point_3;
    auto point = [&mesh](int v) { return Point(mesh.vertices[v].x(), mesh.vertices[v].y(), mesh.vertices[v].z()); };
    size_t collinear = 0;
    for (const Face& f : faces) collinear += CGAL::collinear(point(f[0]), point(f[1]), point(f[2])) ? 1 : 0;
    if (collinear == faces.size()) {
      return core::Status::InvalidArgument(
          Format("every one of its %zu faces is degenerate (zero area: its corners lie on one line)", mesh.triangles.size()));
    }
  }

  // Copies of one face: the same vertex set. How many copies the surface
  // needs follows from the faces around them: with one other face on each
  // of its edges, the face belongs to the surface once (a face written
  // again, perhaps reversed: one copy is kept, the one that agrees with its
  // neighbour). Otherwise copies of opposite orientations cancel in pairs
  // (a face and its reversed copy standing on the surface, as on an edge of
  // four faces, are a zero-volume fin) and one of the rest is kept; whatever
  // is still wrong is diagnosed below.
  {
    std::map<std::array<int, 3>, std::vector<int>> copies;
    for (size_t i = 0; i < faces.size(); ++i) {
      std::array<int, 3> key = faces[i];
      std::sort(key.begin(), key.end());
      copies[key].push_back(static_cast<int>(i));
    }
    // Per edge: the faces on it, each set of copies counted once.
    std::unordered_map<uint64_t, std::vector<int>> edge_groups;
    for (const auto& [key, group] : copies) {
      for (int k = 0; k < 3; ++k) edge_groups[EdgeKey(key[k], key[(k + 1) % 3])].push_back(group[0]);
    }
    std::vector<bool> keep(faces.size(), true);
    for (auto& [key, group] : copies) {
      if (group.size() < 2) continue;
      const Face& first = faces[group[0]];
      std::vector<int> forward, backward;
      for (int i : group) (Traverses(faces[i], first[0], first[1]) ? forward : backward).push_back(i);
      bool one_other_face_per_edge = true;
      for (int k = 0; k < 3; ++k) {
        one_other_face_per_edge = one_other_face_per_edge && edge_groups[EdgeKey(key[k], key[(k + 1) % 3])].size() == 2;
      }
      if (one_other_face_per_edge) {
        // Keep the copy its neighbour across first[0]-first[1] agrees with
        // (traversing that edge the other way), if both orientations exist.
        int neighbour = -1;
        for (int g : edge_groups[EdgeKey(first[0], first[1])]) {
          if (g != group[0]) neighbour = g;
        }
        const bool forward_agrees = neighbour < 0 || !Traverses(faces[neighbour], first[0], first[1]);
        const std::vector<int>& kept_side = (forward_agrees && !forward.empty()) || backward.empty() ? forward : backward;
        const std::vector<int>& other_side = &kept_side == &forward ? backward : forward;
        for (size_t p = 1; p < kept_side.size(); ++p) {
          keep[kept_side[p]] = false;
          ++report.duplicate_faces;
        }
        for (int i : other_side) keep[i] = false;
        report.reversed_duplicate_faces += static_cast<long>(other_side.size());
        continue;
      }
      const size_t pairs = std::min(forward.size(), backward.size());
      report.reversed_duplicate_pairs += static_cast<long>(pairs);
      for (size_t p = 0; p < pairs; ++p) keep[forward[p]] = keep[backward[p]] = false;
      for (const std::vector<int>* side : {&forward, &backward}) {
        for (size_t p = pairs + 1; p < side->size(); ++p) {
          keep[(*side)[p]] = false;
          ++report.duplicate_faces;
        }
      }
    }
    std::vector<Face> kept;
    for (size_t i = 0; i < faces.size(); ++i) {
      if (keep[i]) kept.push_back(faces[i]);
    }
    faces = std::move(kept);
  }
  if (faces.empty()) return core::Status::InvalidArgument("no face is left once duplicates are removed");

  // Edges: which faces use each; more than two is not a surface.
  std::unordered_map<uint64_t, std::vector<int>> edge_faces;
  for (size_t i = 0; i < faces.size(); ++i) {
    for (int k = 0; k < 3; ++k) edge_faces[EdgeKey(faces[i][k], faces[i][(k + 1) % 3])].push_back(static_cast<int>(i));
  }
  std::vector<std::pair<int, int>> border;
  long crowded = 0;
  Vec3 crowded_at = Vec3::Zero();
  for (const auto& [key, users] : edge_faces) {
    const int a = static_cast<int>(key >> 32), b = static_cast<int>(key & 0xffffffffu);
    if (users.size() == 1) border.emplace_back(a, b);
    if (users.size() > 2) {
      if (crowded++ == 0) crowded_at = 0.5 * (mesh.vertices[a] + mesh.vertices[b]);
    }
  }
  if (crowded > 0) {
    return core::Status::InvalidArgument(Format("not a surface: %ld edge%s shared by more than two faces (the first at ",
                                                crowded, crowded == 1 ? "" : "s") +
                                         Point(crowded_at) + ")");
  }
  if (!border.empty()) return core::Status::InvalidArgument(DescribeHoles(border, mesh.vertices));

  // Shells: faces joined through shared edges, each oriented by a walk from
  // its first face (a neighbour must traverse a shared edge the other way).
  std::vector<int> flipped(faces.size(), -1);  // -1: not reached; 0/1: kept/flipped
  std::vector<std::vector<int>> shells;
  for (size_t seed = 0; seed < faces.size(); ++seed) {
    if (flipped[seed] >= 0) continue;
    shells.emplace_back();
    std::queue<int> queue;
    flipped[seed] = 0;
    queue.push(static_cast<int>(seed));
    while (!queue.empty()) {
      const int f = queue.front();
      queue.pop();
      shells.back().push_back(f);
      for (int k = 0; k < 3; ++k) {
        const int a = faces[f][k], b = faces[f][(k + 1) % 3];
        for (int g : edge_faces[EdgeKey(a, b)]) {
          if (g == f) continue;
          // f as oriented now traverses a -> b, or b -> a when flipped.
          const bool f_forward = flipped[f] == 0;
          const bool g_same_way = Traverses(faces[g], a, b) == f_forward;
          const int wanted = g_same_way ? 1 : 0;  // flip g when it runs the same way as f
          if (flipped[g] < 0) {
            flipped[g] = wanted;
            queue.push(g);
          } else if (flipped[g] != wanted) {
            return core::Status::InvalidArgument("a shell cannot be oriented (it is one-sided, like a Moebius strip) "
                                                 "near " + Point(mesh.vertices[a]));
          }
        }
      }
    }
  }
  for (size_t i = 0; i < faces.size(); ++i) {
    if (flipped[i] == 1) std::swap(faces[i][1], faces[i][2]);
  }
  for (const std::vector<int>& shell : shells) {
    long turned = 0;
    for (int f : shell) turned += flipped[f] == 1;
    // The walk kept its first face: the smaller part is the one that was wrong.
    report.flipped_faces += std::min<long>(turned, static_cast<long>(shell.size()) - turned);
  }

  for (size_t s = 0; s < shells.size(); ++s) {
    std::sort(shells[s].begin(), shells[s].end());  // the file's face order, not the walk's
    TriangleMesh part;
    std::unordered_map<int, int> local;
    for (int f : shells[s]) {
      Eigen::Vector3i t;
      for (int k = 0; k < 3; ++k) {
        auto [it, added] = local.emplace(faces[f][k], static_cast<int>(part.vertices.size()));
        if (added) part.vertices.push_back(mesh.vertices[faces[f][k]]);
        t[k] = it->second;
      }
      part.triangles.push_back(t);
    }
    if (SignedVolume(part) < 0.0) {
      for (Eigen::Vector3i& t : part.triangles) std::swap(t[1], t[2]);
      ++report.outward_shells;
    }
    const MeshCheck check = CheckMesh(part);
    if (!check.bounds_volume || !check.outward) {
      const AxisAlignedBox box = BoundingBox(part);
      return core::Status::InvalidArgument(Format("shell %zu of %zu (", s + 1, shells.size()) +
                                           Plural(static_cast<long>(part.triangles.size()), "face", "faces") +
                                           ", from " + Point(box.min) + " to " + Point(box.max) +
                                           ") does not bound a volume: " + check.problem);
    }
    result.shells.push_back(std::move(part));
  }
  report.shells = static_cast<long>(result.shells.size());
  return result;
}

}  // namespace quadhand::geometry
