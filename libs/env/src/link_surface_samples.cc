#include "quadhand/env/link_surface_samples.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <tuple>

namespace quadhand::env {
namespace {

using Key = std::array<long long, 3>;

Key Quantize(const Vec3& p, double step) {
  return {static_cast<long long>(std::llround(p.x() / step)), static_cast<long long>(std::llround(p.y() / step)),
          static_cast<long long>(std::llround(p.z() / step))};
}

}  // namespace

LinkSurfaceSamples SampleLinkSurface(const geometry::TriangleMesh& mesh, double spacing, double cluster_size) {
  LinkSurfaceSamples out;
  out.vertices = mesh.vertices;
  // Corners of the sub-triangles, keyed by a 1e-7 m quantisation so the points
  // on an edge shared by two triangles are kept once.
  std::vector<std::pair<Key, Vec3>> raw;  // (quantised key, point)
  // A triangle no larger than one row of one step yields only its corners:
  // they are taken once per vertex below instead of once per triangle (a
  // CAD mesh of small triangles would otherwise put each vertex six times
  // into the sort).
  std::vector<bool> corner_only(mesh.vertices.size(), false);
  const double row_gap = spacing * std::sqrt(3.0) / 2.0;
  for (const Eigen::Vector3i& t : mesh.triangles) {
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
    if (rows == 1 && std::max(1, static_cast<int>(std::ceil(longest / spacing - 1e-9))) == 1) {
      for (int k = 0; k < 3; ++k) corner_only[t[k]] = true;
      continue;
    }
    for (int k = 0; k <= rows; ++k) {
      if (k == rows) {
        raw.emplace_back(Quantize(r, 1e-7), r);
        break;
      }
      const double f = static_cast<double>(k) / rows;
      const Vec3 a = k == 0 ? p : Vec3(p + f * pr);
      const Vec3 b = k == 0 ? q : Vec3(q + f * (r - q));
      const int n = std::max(1, static_cast<int>(std::ceil((1.0 - f) * longest / spacing - 1e-9)));
      for (int i = 0; i <= n; ++i) {
        const Vec3 x = i == 0 ? a : i == n ? b : Vec3(a + (static_cast<double>(i) / n) * (b - a));
        raw.emplace_back(Quantize(x, 1e-7), x);
      }
    }
  }
  for (size_t v = 0; v < mesh.vertices.size(); ++v) {
    if (corner_only[v]) raw.emplace_back(Quantize(mesh.vertices[v], 1e-7), mesh.vertices[v]);
  }
  // One sort by cluster cell, then quantised position: duplicates become
  // neighbours (the cell is taken from the quantised position, so copies of
  // a point share it) and each cluster one run.
  struct Keyed {
    Key cell;
    Key quantised;
    Vec3 point;
  };
  std::vector<Keyed> keyed;
  keyed.reserve(raw.size());
  const double cell_per_step = 1e-7 / cluster_size;
  for (const auto& [quantised, p] : raw) {
    keyed.push_back({Key{static_cast<long long>(std::floor(static_cast<double>(quantised[0]) * cell_per_step)),
                         static_cast<long long>(std::floor(static_cast<double>(quantised[1]) * cell_per_step)),
                         static_cast<long long>(std::floor(static_cast<double>(quantised[2]) * cell_per_step))},
                     quantised, p});
  }
  std::sort(keyed.begin(), keyed.end(), [](const Keyed& x, const Keyed& y) {
    return std::tie(x.cell, x.quantised) < std::tie(y.cell, y.quantised);
  });
  keyed.erase(std::unique(keyed.begin(), keyed.end(),
                          [](const Keyed& x, const Keyed& y) { return x.quantised == y.quantised; }),
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
