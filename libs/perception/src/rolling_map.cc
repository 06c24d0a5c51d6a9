#include "quadhand/perception/rolling_map.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include <octomap/OcTree.h>

namespace quadhand::perception {
namespace {

bool Fail(std::string* why, const std::string& message) {
  if (why != nullptr) *why = message;
  return false;
}

bool In(double x, double lo, double hi) { return std::isfinite(x) && x >= lo && x <= hi; }

octomap::point3d ToOcto(const Vec3& p) {
  return octomap::point3d(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()));
}

}  // namespace

bool RollingMapOptions::IsValid(std::string* why) const {
  if (!In(resolution, 0.005, 5.0)) return Fail(why, "resolution must be in [0.005, 5] m");
  if (!window_half_extent.allFinite() || (window_half_extent.array() < resolution).any() ||
      (window_half_extent.array() > 1e4).any()) {
    return Fail(why, "window_half_extent must be in [resolution, 10000] m on every axis");
  }
  if (!In(max_range, resolution, 1e4)) return Fail(why, "max_range must be in [resolution, 10000] m");
  if (!In(probability_hit, 0.5, 1.0) || !(probability_hit < 1.0)) return Fail(why, "probability_hit must be in (0.5, 1)");
  if (!In(probability_miss, 0.0, 0.5) || !(probability_miss > 0.0) || !(probability_miss < 0.5)) {
    return Fail(why, "probability_miss must be in (0, 0.5)");
  }
  if (!In(occupied_threshold, 0.0, 1.0) || !(occupied_threshold > 0.0 && occupied_threshold < 1.0)) {
    return Fail(why, "occupied_threshold must be in (0, 1)");
  }
  if (max_points_per_voxel < 1 || max_points_per_voxel > 1000) return Fail(why, "max_points_per_voxel must be in [1, 1000]");
  return true;
}

struct RollingMap::Impl {
  explicit Impl(const RollingMapOptions& o) : options(o), tree(o.resolution) {
    tree.setProbHit(o.probability_hit);
    tree.setProbMiss(o.probability_miss);
    tree.setOccupancyThres(o.occupied_threshold);
  }
  bool InWindow(const Vec3& p) const {
    return ((p - centre).cwiseAbs().array() <= options.window_half_extent.array()).all();
  }
  bool Occupied(const octomap::OcTreeKey& key) const {
    const octomap::OcTreeNode* node = tree.search(key);
    return node != nullptr && tree.isNodeOccupied(node);
  }

  RollingMapOptions options;
  octomap::OcTree tree;
  Vec3 centre = Vec3::Zero();
  // The raw returns of each voxel a return ended in (occupied, or until a
  // later frame frees it), at most max_points_per_voxel, the newest kept.
  std::unordered_map<octomap::OcTreeKey, std::vector<Vec3>, octomap::OcTreeKey::KeyHash> raw;
  long frames = 0;
  long dropped = 0;
};

RollingMap::RollingMap(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
RollingMap::~RollingMap() = default;

core::Result<std::unique_ptr<RollingMap>> RollingMap::Create(const RollingMapOptions& options) {
  if (std::string why; !options.IsValid(&why)) return core::Status::InvalidArgument("rolling map: " + why);
  return std::unique_ptr<RollingMap>(new RollingMap(std::make_unique<Impl>(options)));
}

core::Status RollingMap::Insert(const std::vector<Vec3>& points, const Vec3& origin) {
  Impl& m = *impl_;
  if (!origin.allFinite()) return core::Status::InvalidArgument("rolling map: a frame's sensor origin is not finite");
  octomap::Pointcloud cloud;
  cloud.reserve(points.size());
  std::vector<const Vec3*> near;
  near.reserve(points.size());
  for (const Vec3& p : points) {
    if (!p.allFinite()) {
      ++m.dropped;
      continue;
    }
    cloud.push_back(ToOcto(p));
    if ((p - origin).norm() <= m.options.max_range) near.push_back(&p);
  }
  // discretize: one ray per end voxel (a frame's many returns per voxel
  // would cast the same ray again and again).
  m.tree.insertPointCloud(cloud, ToOcto(origin), m.options.max_range, /*lazy_eval=*/false, /*discretize=*/true);
  const size_t cap = static_cast<size_t>(m.options.max_points_per_voxel);
  for (const Vec3* p : near) {
    std::vector<Vec3>& kept = m.raw[m.tree.coordToKey(ToOcto(*p))];
    if (kept.size() < cap) {
      kept.push_back(*p);
    } else {
      kept[static_cast<size_t>(m.frames) % cap] = *p;
    }
  }
  ++m.frames;
  return core::Status::Ok();
}

void RollingMap::MoveWindow(const Vec3& centre) {
  Impl& m = *impl_;
  if (!centre.allFinite()) return;
  m.centre = centre;
  // The tree is rebuilt from its leaves inside the window (their log-odds
  // as they are; a pruned leaf, a cube of equal voxels, by its voxels
  // inside): what left the window is gone, not merely hidden.
  octomap::OcTree kept(m.options.resolution);
  kept.setProbHit(m.options.probability_hit);
  kept.setProbMiss(m.options.probability_miss);
  kept.setOccupancyThres(m.options.occupied_threshold);
  const unsigned max_depth = m.tree.getTreeDepth();
  for (auto leaf = m.tree.begin_leafs(), end = m.tree.end_leafs(); leaf != end; ++leaf) {
    const float log_odds = leaf->getLogOdds();
    if (leaf.getDepth() == max_depth) {
      const octomap::point3d c = leaf.getCoordinate();
      if (m.InWindow(Vec3(c.x(), c.y(), c.z()))) kept.setNodeValue(leaf.getKey(), log_odds, /*lazy_eval=*/true);
      continue;
    }
    const double half = 0.5 * leaf.getSize(), step = m.options.resolution;
    const octomap::point3d c = leaf.getCoordinate();
    for (double x = c.x() - half + 0.5 * step; x < c.x() + half; x += step) {
      for (double y = c.y() - half + 0.5 * step; y < c.y() + half; y += step) {
        for (double z = c.z() - half + 0.5 * step; z < c.z() + half; z += step) {
          if (m.InWindow(Vec3(x, y, z))) kept.setNodeValue(ToOcto(Vec3(x, y, z)), log_odds, /*lazy_eval=*/true);
        }
      }
    }
  }
  kept.updateInnerOccupancy();
  kept.prune();
  m.tree.swapContent(kept);
  for (auto it = m.raw.begin(); it != m.raw.end();) {
    const octomap::point3d c = m.tree.keyToCoord(it->first);
    if (!m.InWindow(Vec3(c.x(), c.y(), c.z())) || !m.Occupied(it->first)) {
      it = m.raw.erase(it);
    } else {
      ++it;
    }
  }
}

VoxelState RollingMap::State(const Vec3& p) const {
  const Impl& m = *impl_;
  if (!p.allFinite() || !m.InWindow(p)) return VoxelState::kUnknown;
  const octomap::OcTreeNode* node = m.tree.search(ToOcto(p));
  if (node == nullptr) return VoxelState::kUnknown;
  return m.tree.isNodeOccupied(node) ? VoxelState::kOccupied : VoxelState::kFree;
}

std::vector<Vec3> RollingMap::OccupiedPoints() const {
  const Impl& m = *impl_;
  std::vector<Vec3> points;
  for (const auto& [key, kept] : m.raw) {
    if (!m.Occupied(key)) continue;
    for (const Vec3& p : kept) {
      if (m.InWindow(p)) points.push_back(p);
    }
  }
  return points;
}

std::vector<Vec3> RollingMap::UnknownVoxelCentres(const Vec3& lo, const Vec3& hi) const {
  const Impl& m = *impl_;
  std::vector<Vec3> centres;
  if (!lo.allFinite() || !hi.allFinite()) return centres;
  const Vec3 from = lo.cwiseMax(m.centre - m.options.window_half_extent);
  const Vec3 to = hi.cwiseMin(m.centre + m.options.window_half_extent);
  if ((from.array() > to.array()).any()) return centres;
  const octomap::OcTreeKey first = m.tree.coordToKey(ToOcto(from)), last = m.tree.coordToKey(ToOcto(to));
  octomap::OcTreeKey key;
  for (unsigned i = first[0]; i <= last[0]; ++i) {
    key[0] = static_cast<octomap::key_type>(i);
    for (unsigned j = first[1]; j <= last[1]; ++j) {
      key[1] = static_cast<octomap::key_type>(j);
      for (unsigned k = first[2]; k <= last[2]; ++k) {
        key[2] = static_cast<octomap::key_type>(k);
        if (m.tree.search(key) != nullptr) continue;
        const octomap::point3d c = m.tree.keyToCoord(key);
        centres.emplace_back(c.x(), c.y(), c.z());
      }
    }
  }
  return centres;
}

const RollingMapOptions& RollingMap::options() const { return impl_->options; }
Vec3 RollingMap::window_centre() const { return impl_->centre; }
long RollingMap::frames() const { return impl_->frames; }
long RollingMap::dropped_points() const { return impl_->dropped; }
size_t RollingMap::num_known_voxels() const { return impl_->tree.getNumLeafNodes(); }

size_t RollingMap::memory_bytes() const {
  const Impl& m = *impl_;
  size_t bytes = m.tree.memoryUsage();
  for (const auto& entry : m.raw) bytes += sizeof(entry) + entry.second.capacity() * sizeof(Vec3);
  return bytes;
}

}  // namespace quadhand::perception
