#include "quadhand/explore/guide.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>

namespace quadhand::explore {

Guide Guide::Compute(const perception::RollingMap& map, const Vec3& goal, double cell, double height_range) {
  Guide guide;
  if (!(cell > 0.0) || !std::isfinite(cell) || !goal.allFinite() || !(height_range >= 0.0)) return guide;
  const Vec3 half = map.options().window_half_extent;
  const Vec3 centre = map.window_centre();
  Vec3 lo = centre - half, hi = centre + half;
  lo.z() = std::max(lo.z(), goal.z() - height_range - cell);
  hi.z() = std::min(hi.z(), goal.z() + height_range + cell);
  if ((hi.array() <= lo.array()).any()) return guide;
  guide.lo_ = lo;
  guide.cell_ = cell;
  for (int a = 0; a < 3; ++a) guide.dims_[a] = std::max(1, static_cast<int>(std::ceil((hi[a] - lo[a]) / cell)));
  const Eigen::Vector3i dims = guide.dims_;
  const size_t count = static_cast<size_t>(dims.x()) * dims.y() * dims.z();
  auto index = [&](int i, int j, int k) { return (static_cast<size_t>(i) * dims.y() + j) * dims.z() + k; };
  auto cell_of = [&](const Vec3& p, Eigen::Vector3i* c) {
    for (int a = 0; a < 3; ++a) {
      const double u = std::floor((p[a] - lo[a]) / cell);
      if (u < 0.0 || u >= dims[a]) return false;
      (*c)[a] = static_cast<int>(u);
    }
    return true;
  };
  auto centre_of = [&](int i, int j, int k) { return Vec3(lo + (Vec3(i, j, k).array() + 0.5).matrix() * cell); };

  // The search runs on a copy padded by one blocked cell on every side, so
  // that neighbours need no bounds checks, in integer units of a tenth of a
  // cell with a bucket queue (Dial's): a step costs 10, 14 or 17 units.
  const Eigen::Vector3i padded = dims + Eigen::Vector3i::Constant(2);
  const size_t padded_count = static_cast<size_t>(padded.x()) * padded.y() * padded.z();
  const long stride_j = padded.z(), stride_i = static_cast<long>(padded.y()) * padded.z();
  auto padded_index = [&](int i, int j, int k) {
    return static_cast<size_t>((i + 1) * stride_i + (j + 1) * stride_j + (k + 1));
  };
  std::vector<std::uint8_t> blocked(padded_count, 1);
  for (int i = 0; i < dims.x(); ++i) {
    for (int j = 0; j < dims.y(); ++j) {
      std::fill_n(blocked.begin() + static_cast<long>(padded_index(i, j, 0)), dims.z(), std::uint8_t{0});
    }
  }
  for (const Vec3& v : map.OccupiedVoxelCentres()) {
    Eigen::Vector3i c;
    if (!cell_of(v, &c)) continue;
    std::uint8_t& b = blocked[padded_index(c.x(), c.y(), c.z())];
    guide.blocked_ += b == 0;
    b = 1;
  }
  constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();
  const double unit = cell / 10.0;
  std::vector<std::uint32_t> units(padded_count, kNone);
  constexpr int kBuckets = 18;  // more than the longest step
  std::vector<std::vector<std::uint32_t>> buckets(kBuckets);
  // Seeds may be far apart in cost: kept sorted and let in as the search
  // reaches their cost.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> seeds;
  auto seed = [&](int i, int j, int k, double metres) {
    seeds.emplace_back(static_cast<std::uint32_t>(std::lround(metres / unit)),
                       static_cast<std::uint32_t>(padded_index(i, j, k)));
  };
  Eigen::Vector3i goal_cell;
  if (cell_of(goal, &goal_cell)) {
    // The goal's own cell is where the way ends, even next to a wall.
    blocked[padded_index(goal_cell.x(), goal_cell.y(), goal_cell.z())] = 0;
    seed(goal_cell.x(), goal_cell.y(), goal_cell.z(), (centre_of(goal_cell.x(), goal_cell.y(), goal_cell.z()) - goal).norm());
  } else {
    // Beyond the window nothing is known: straight on from its border.
    for (int i = 0; i < dims.x(); ++i) {
      for (int j = 0; j < dims.y(); ++j) {
        const bool side = i == 0 || j == 0 || i == dims.x() - 1 || j == dims.y() - 1;
        for (int k = 0; k < dims.z(); k += side || dims.z() < 2 ? 1 : dims.z() - 1) {
          if (blocked[padded_index(i, j, k)]) continue;
          seed(i, j, k, (centre_of(i, j, k) - goal).norm());
        }
      }
    }
  }
  std::sort(seeds.begin(), seeds.end());
  struct Step {
    long offset;
    std::uint32_t length;
  };
  std::vector<Step> steps;
  for (int di = -1; di <= 1; ++di) {
    for (int dj = -1; dj <= 1; ++dj) {
      for (int dk = -1; dk <= 1; ++dk) {
        const int squares = di * di + dj * dj + dk * dk;
        if (squares == 0) continue;
        steps.push_back({di * stride_i + dj * stride_j + dk, squares == 1 ? 10u : squares == 2 ? 14u : 17u});
      }
    }
  }
  size_t next_seed = 0, queued = 0;
  for (std::uint32_t now = seeds.empty() ? 0 : seeds.front().first; next_seed < seeds.size() || queued > 0; ++now) {
    while (next_seed < seeds.size() && seeds[next_seed].first <= now) {
      const auto [cost, n] = seeds[next_seed++];
      if (units[n] <= cost) continue;
      units[n] = cost;
      buckets[cost % kBuckets].push_back(n);
      ++queued;
    }
    std::vector<std::uint32_t>& bucket = buckets[now % kBuckets];
    // (The bucket grows while it is walked: steps of 10+ units never land
    // in it, so it does not.)
    for (size_t b = 0; b < bucket.size(); ++b) {
      const std::uint32_t n = bucket[b];
      --queued;
      if (units[n] != now) continue;  // reached more cheaply since
      for (const Step& s : steps) {
        const size_t m = static_cast<size_t>(static_cast<long>(n) + s.offset);
        if (blocked[m]) continue;
        const std::uint32_t next = now + s.length;
        if (next < units[m]) {
          units[m] = next;
          buckets[next % kBuckets].push_back(static_cast<std::uint32_t>(m));
          ++queued;
        }
      }
    }
    bucket.clear();
  }
  guide.cost_.assign(count, std::numeric_limits<float>::infinity());
  for (int i = 0; i < dims.x(); ++i) {
    for (int j = 0; j < dims.y(); ++j) {
      for (int k = 0; k < dims.z(); ++k) {
        const std::uint32_t u = units[padded_index(i, j, k)];
        if (u != kNone) guide.cost_[index(i, j, k)] = static_cast<float>(u * unit);
      }
    }
  }
  return guide;
}

double Guide::CostAt(const Vec3& p) const {
  if (cost_.empty() || !p.allFinite()) return kUnreachable;
  // Through the nearest reached of the (up to) eight cell centres about p:
  // a point ranks by the way on from the centres around it, so that of two
  // points in one cell the one further along the way ranks first.
  Eigen::Vector3i below;
  for (int a = 0; a < 3; ++a) {
    const double u = (p[a] - lo_[a]) / cell_;
    if (u < 0.0 || u >= dims_[a]) return kUnreachable;
    below[a] = static_cast<int>(std::floor(u - 0.5));
  }
  double best = kUnreachable;
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Vector3i c = below + Eigen::Vector3i(corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
    if ((c.array() < 0).any() || (c.array() >= dims_.array()).any()) continue;
    const float cost = cost_[(static_cast<size_t>(c.x()) * dims_.y() + c.y()) * dims_.z() + c.z()];
    if (!std::isfinite(cost)) continue;
    best = std::min(best, cost + (p - (lo_ + (c.cast<double>().array() + 0.5).matrix() * cell_)).norm());
  }
  return best;
}

}  // namespace quadhand::explore
