#include "quadhand/env/link_surface_samples.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <tuple>

namespace quadhand::env {
namespace {

using Key = std::array<long long, 3>;

Key Quantize(const Vec3& p, double step) {
  return {static_cast<long long>(std::llround(p.x() / step)), static_cast<long long>(std::llround(p.y() / step)),
          static_cast<long long>(std::llround(p.z() / step))};
}

double SurfaceArea(const geometry::TriangleMesh& mesh) {
  double area = 0.0;
  for (const Eigen::Vector3i& t : mesh.triangles) {
    area += 0.5 * (mesh.vertices[t[1]] - mesh.vertices[t[0]]).cross(mesh.vertices[t[2]] - mesh.vertices[t[0]]).norm();
  }
  return area;
}

}  // namespace

double EstimatedSurfaceSampleCount(const geometry::TriangleMesh& mesh, double spacing) {
  return SurfaceArea(mesh) / (spacing * spacing * std::sqrt(3.0) / 2.0) + static_cast<double>(mesh.vertices.size());
}

core::Status CheckSurfaceSampleCount(const geometry::TriangleMesh& mesh, double spacing, const std::string& what) {
  const double count = EstimatedSurfaceSampleCount(mesh, spacing);
  if (count <= kMaxSurfaceSamples) return core::Status::Ok();
  Vec3 lo = Vec3::Constant(1e300), hi = Vec3::Constant(-1e300);
  for (const Vec3& v : mesh.vertices) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  const double area = SurfaceArea(mesh);
  const Vec3 size = hi - lo;
  char text[320];
  std::snprintf(text, sizeof(text),
                "the collision mesh is %.3g x %.3g x %.3g m with %.3g m^2 of surface; sampling it every %g mm "
                "needs %.2g points, more than %.0g (a mesh in millimetres needs scale=\"0.001\" in the URDF)",
                size.x(), size.y(), size.z(), area, spacing * 1e3, count, kMaxSurfaceSamples);
  return core::Status::InvalidArgument(what + ": " + text);
}

LinkSurfaceSamples SampleLinkSurface(const geometry::TriangleMesh& mesh, double spacing, double cluster_size) {
  LinkSurfaceSamples out;
  out.vertices = mesh.vertices;
  // The samples: every vertex of a triangle, taken once per vertex (a CAD
  // mesh's small triangles give nothing else, and its vertices are most of
  // the samples), and the points on the edges and inside larger triangles.
  std::vector<bool> is_corner(mesh.vertices.size(), false);
  std::vector<std::pair<Key, Vec3>> inner;  // (quantised key, point)
  const double row_gap = spacing * std::sqrt(3.0) / 2.0;
  const double small_squared = row_gap * row_gap;
  for (const Eigen::Vector3i& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) is_corner[t[k]] = true;
    // No edge longer than the row gap: one row of one step, its corners
    // only (most of a CAD mesh's triangles; no root taken).
    const Vec3& v0 = mesh.vertices[t[0]];
    const Vec3& v1 = mesh.vertices[t[1]];
    const Vec3& v2 = mesh.vertices[t[2]];
    if ((v1 - v0).squaredNorm() <= small_squared && (v2 - v1).squaredNorm() <= small_squared &&
        (v0 - v2).squaredNorm() <= small_squared) {
      continue;
    }
    // Rows parallel to the longest edge pq, from it to the opposite vertex r.
    int e = 0;
    double longest = -1.0;
    for (int k = 0; k < 3; ++k) {
      const double length = (mesh.vertices[t[(k + 1) % 3]] - mesh.vertices[t[k]]).norm();
      if (length > longest) {
        longest = length;
        e = k;
      }
    }
    const Vec3& p = mesh.vertices[t[e]];
    const Vec3& q = mesh.vertices[t[(e + 1) % 3]];
    const Vec3& r = mesh.vertices[t[(e + 2) % 3]];
    const Vec3 pr = r - p;
    const double height = longest > 0.0 ? pr.cross(q - p).norm() / longest : 0.0;
    const int rows = std::max(1, static_cast<int>(std::ceil(height / row_gap - 1e-9)));
    // Row k < rows runs from a on pr to b on qr in n steps; the last row is r.
    for (int k = 0; k < rows; ++k) {
      const double f = static_cast<double>(k) / rows;
      const Vec3 a = k == 0 ? p : Vec3(p + f * pr);
      const Vec3 b = k == 0 ? q : Vec3(q + f * (r - q));
      const int n = std::max(1, static_cast<int>(std::ceil((1.0 - f) * longest / spacing - 1e-9)));
      for (int i = 0; i <= n; ++i) {
        if (k == 0 && (i == 0 || i == n)) continue;  // p and q: corners
        const Vec3 x = i == 0 ? a : i == n ? b : Vec3(a + (static_cast<double>(i) / n) * (b - a));
        inner.emplace_back(Quantize(x, 1e-7), x);
      }
    }
  }
  // Grouped by cluster cell, each cell in order of quantised position (a
  // 1e-7 m grid), a position kept once: the points of an edge shared by two
  // triangles, and a vertex another triangle's row meets. Among near-equal
  // points the least by coordinates is kept, whatever order they came in.
  // One sort; the cell is packed into 64 bits (21 bits an axis, from the
  // lowest cell) whenever the link spans fewer than two million cells an
  // axis, as any real one does, so most comparisons are of one integer.
  struct Keyed {
    uint64_t packed;  // the cell, packed; 0 for all when it does not fit
    uint64_t local;   // the quantised position within its cell, packed; 0 for all when it does not fit
    Key cell;
    Key quantised;
    Vec3 point;
  };
  std::vector<Keyed> keyed;
  keyed.reserve(inner.size() + mesh.vertices.size());
  auto add = [&](const Key& quantised, const Vec3& x) {
    const Key cell = {static_cast<long long>(std::floor(x.x() / cluster_size)),
                      static_cast<long long>(std::floor(x.y() / cluster_size)),
                      static_cast<long long>(std::floor(x.z() / cluster_size))};
    keyed.push_back({0, 0, cell, quantised, x});
  };
  for (size_t v = 0; v < mesh.vertices.size(); ++v) {
    if (is_corner[v]) add(Quantize(mesh.vertices[v], 1e-7), mesh.vertices[v]);
  }
  for (const auto& [quantised, x] : inner) add(quantised, x);
  if (!keyed.empty()) {
    Key lowest = keyed.front().cell, highest = lowest;
    for (const Keyed& k : keyed) {
      for (int axis = 0; axis < 3; ++axis) {
        lowest[axis] = std::min(lowest[axis], k.cell[axis]);
        highest[axis] = std::max(highest[axis], k.cell[axis]);
      }
    }
    constexpr long long kAxisCells = 1ll << 21;
    if (highest[0] - lowest[0] < kAxisCells && highest[1] - lowest[1] < kAxisCells &&
        highest[2] - lowest[2] < kAxisCells) {
      for (Keyed& k : keyed) {
        const auto offset = [&](int axis) { return static_cast<uint64_t>(k.cell[axis] - lowest[axis]); };
        k.packed = (offset(0) << 42) | (offset(1) << 21) | offset(2);
      }
      // Within a cell the quantised positions span cluster_size / 1e-7 steps
      // an axis (19 bits at the default 4 cm): packed too, relative to a
      // base below the cell's corner, when three of them fit in 64 bits.
      const double steps_per_cell = cluster_size / 1e-7;
      const int bits = static_cast<int>(std::ceil(std::log2(steps_per_cell + 16.0)));
      if (bits <= 21) {
        bool fits = true;
        for (Keyed& k : keyed) {
          uint64_t local = 0;
          for (int axis = 0; axis < 3; ++axis) {
            const long long base = static_cast<long long>(std::floor(static_cast<double>(k.cell[axis]) * steps_per_cell)) - 4;
            const long long offset = k.quantised[axis] - base;
            fits = fits && offset >= 0 && offset < (1ll << bits);
            local = (local << bits) | static_cast<uint64_t>(std::max(0ll, offset));
          }
          k.local = local;
        }
        if (!fits) {
          for (Keyed& k : keyed) k.local = 0;
        }
      }
    }
  }
  std::sort(keyed.begin(), keyed.end(), [](const Keyed& x, const Keyed& y) {
    return std::tie(x.packed, x.local, x.cell, x.quantised, x.point.x(), x.point.y(), x.point.z()) <
           std::tie(y.packed, y.local, y.cell, y.quantised, y.point.x(), y.point.y(), y.point.z());
  });
  keyed.erase(std::unique(keyed.begin(), keyed.end(),
                          [](const Keyed& x, const Keyed& y) { return x.cell == y.cell && x.quantised == y.quantised; }),
              keyed.end());
  out.points.reserve(keyed.size());
  for (size_t i = 0; i < keyed.size();) {
    size_t j = i;
    Vec3 lo = keyed[i].point, hi = keyed[i].point;
    while (j < keyed.size() && keyed[j].cell == keyed[i].cell) {
      lo = lo.cwiseMin(keyed[j].point);
      hi = hi.cwiseMax(keyed[j].point);
      ++j;
    }
    LinkSurfaceSamples::Cluster cluster;
    cluster.begin = static_cast<int>(out.points.size());
    cluster.center = 0.5 * (lo + hi);
    for (size_t k = i; k < j; ++k) {
      out.points.push_back(keyed[k].point);
      cluster.radius = std::max(cluster.radius, (keyed[k].point - cluster.center).norm());
    }
    cluster.end = static_cast<int>(out.points.size());
    out.clusters.push_back(cluster);
    i = j;
  }
  return out;
}

}  // namespace quadhand::env
