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
  std::sort(raw.begin(), raw.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
  raw.erase(std::unique(raw.begin(), raw.end(), [](const auto& x, const auto& y) { return x.first == y.first; }),
            raw.end());

  // Group by cluster cell.
  std::vector<std::pair<Key, Vec3>> keyed;
  keyed.reserve(raw.size());
  for (const auto& [unused, p] : raw) {
    keyed.emplace_back(Key{static_cast<long long>(std::floor(p.x() / cluster_size)),
                           static_cast<long long>(std::floor(p.y() / cluster_size)),
                           static_cast<long long>(std::floor(p.z() / cluster_size))},
                       p);
  }
  std::stable_sort(keyed.begin(), keyed.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
  out.points.reserve(keyed.size());
  for (size_t i = 0; i < keyed.size();) {
    size_t j = i;
    Vec3 lo = keyed[i].second, hi = keyed[i].second;
    while (j < keyed.size() && keyed[j].first == keyed[i].first) {
      lo = lo.cwiseMin(keyed[j].second);
      hi = hi.cwiseMax(keyed[j].second);
      ++j;
    }
    LinkSurfaceSamples::Cluster cluster;
    cluster.begin = static_cast<int>(out.points.size());
    cluster.center = 0.5 * (lo + hi);
    for (size_t k = i; k < j; ++k) {
      out.points.push_back(keyed[k].second);
      cluster.radius = std::max(cluster.radius, (keyed[k].second - cluster.center).norm());
    }
    cluster.end = static_cast<int>(out.points.size());
    out.clusters.push_back(cluster);
    i = j;
  }
  return out;
}

}  // namespace quadhand::env
