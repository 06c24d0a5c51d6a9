#include "quadhand/planner/front_end.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>

#include "quadhand/core/text.h"

namespace quadhand::planner {
namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

std::string Format(double x) { return core::Format("%g", x); }

std::string Format(const Vec3& p) { return core::Format("(%g, %g, %g)", p.x(), p.y(), p.z()); }

bool Fail(std::string* why, const std::string& message) {
  if (why != nullptr) *why = message;
  return false;
}

// Squared distance from q to the segment [a, b].
double SquaredDistanceToSegment(const Vec3& q, const Vec3& a, const Vec3& b) {
  const Vec3 ab = b - a;
  const double len2 = ab.squaredNorm();
  double t = len2 > 0.0 ? (q - a).dot(ab) / len2 : 0.0;
  t = std::clamp(t, 0.0, 1.0);
  return (a + t * ab - q).squaredNorm();
}

// A* costs are integers (thousandths of a voxel), so that g + h is exactly
// constant along every shortest grid path in free space and ties are exact:
// the deepest node then wins, and the search dives instead of flooding.
constexpr int kCost1 = 1000, kCost2 = 1414, kCost3 = 1732;

// Octile distance on the 26-connected grid, in the same integer units.
int Octile(int di, int dj, int dk) {
  int d[3] = {std::abs(di), std::abs(dj), std::abs(dk)};
  std::sort(d, d + 3);
  return kCost3 * d[0] + kCost2 * (d[1] - d[0]) + kCost1 * (d[2] - d[1]);
}

// Per-thread A* scratch, reused across queries and maps: a node is "seen"
// in the current query when stamp == current and "closed" when stamp ==
// current + 1. A grid of up to kDenseScratchVoxels has a cell per voxel
// (the node's own index: the fastest); a larger one, in blocks of the map's
// (`block_voxels` each) given a slot when the search first touches them.
constexpr long kDenseScratchVoxels = 2'000'000;
struct SearchScratch {
  bool dense = false;
  std::vector<int> slot_of_block;  // this query's: -1 until touched
  std::vector<int> g;
  std::vector<int> parent;
  std::vector<std::uint32_t> stamp;
  int slots = 0;
  int block_voxels = 0;
  std::uint32_t current = 0;

  void Prepare(long grid_voxels, long blocks, int voxels_per_block) {
    dense = grid_voxels <= kDenseScratchVoxels;
    if (dense && static_cast<long>(stamp.size()) < grid_voxels) {
      g.resize(grid_voxels);
      parent.resize(grid_voxels);
      stamp.resize(grid_voxels, 0);
    }
    slot_of_block.assign(dense ? 0 : static_cast<size_t>(blocks), -1);
    slots = 0;
    block_voxels = voxels_per_block;
    if (current >= std::numeric_limits<std::uint32_t>::max() - 4) {
      std::fill(stamp.begin(), stamp.end(), 0);
      current = 0;
    }
    current += 2;
  }
  // The scratch cell of `node` (voxel `in_block` of `block`).
  long Cell(int node, long block, int in_block) {
    if (dense) return node;
    int& slot = slot_of_block[static_cast<size_t>(block)];
    if (slot < 0) {
      slot = slots++;
      const size_t size = static_cast<size_t>(slots) * block_voxels;
      if (stamp.size() < size) {
        g.resize(size);
        parent.resize(size);
        stamp.resize(size, 0);  // older queries' stamps are below current
      }
    }
    return static_cast<long>(slot) * block_voxels + in_block;
  }
};

struct OpenEntry {
  int f;
  int g;
  int node;
};

// The open list: lowest f first; then deepest (largest g); then lowest
// index. A 4-ary heap on one 64-bit key for (f, -g) and the index: half the
// depth of a binary heap, one comparison for most pairs, the same order.
class OpenList {
 public:
  void Reserve(size_t n) { heap_.reserve(n); }
  bool empty() const { return heap_.empty(); }
  void Push(const OpenEntry& entry) {
    Item item{(static_cast<std::uint64_t>(entry.f) << 32) | static_cast<std::uint32_t>(kMaxG - entry.g), entry.node};
    size_t at = heap_.size();
    heap_.push_back(item);
    while (at > 0) {
      const size_t parent = (at - 1) / 4;
      if (!Before(item, heap_[parent])) break;
      heap_[at] = heap_[parent];
      at = parent;
    }
    heap_[at] = item;
  }
  OpenEntry Pop() {
    const Item top = heap_.front();
    const Item last = heap_.back();
    heap_.pop_back();
    const size_t n = heap_.size();
    if (n > 0) {
      size_t at = 0;
      for (;;) {
        const size_t first = 4 * at + 1;
        if (first >= n) break;
        size_t best = first;
        const size_t end = std::min(first + 4, n);
        for (size_t c = first + 1; c < end; ++c) {
          if (Before(heap_[c], heap_[best])) best = c;
        }
        if (!Before(heap_[best], last)) break;
        heap_[at] = heap_[best];
        at = best;
      }
      heap_[at] = last;
    }
    return {static_cast<int>(top.key >> 32), kMaxG - static_cast<int>(top.key & 0xffffffffu), top.node};
  }

 private:
  static constexpr int kMaxG = std::numeric_limits<int>::max();
  struct Item {
    std::uint64_t key;  // f in the high half, kMaxG - g in the low half
    int node;
  };
  static bool Before(const Item& a, const Item& b) { return a.key < b.key || (a.key == b.key && a.node < b.node); }
  std::vector<Item> heap_;
};

std::vector<Vec3> WithoutRepeats(const std::vector<Vec3>& path) {
  std::vector<Vec3> out;
  for (const Vec3& p : path) {
    if (out.empty() || (p - out.back()).norm() > 1e-9) out.push_back(p);
  }
  return out;
}

}  // namespace

bool FrontEndOptions::IsValid(std::string* why) const {
  if (!(voxel_size > 0.0) || !std::isfinite(voxel_size)) return Fail(why, "voxel_size must be positive and finite");
  if (!(inflation_radius >= 0.0) || !std::isfinite(inflation_radius)) {
    return Fail(why, "inflation_radius must be non-negative and finite");
  }
  if (!(inflation_height >= 0.0) || !std::isfinite(inflation_height)) {
    return Fail(why, "inflation_height must be non-negative and finite");
  }
  if (!(tight_cost_factor >= 1.0 && tight_cost_factor <= 1000.0)) {
    return Fail(why, "tight_cost_factor must be in [1, 1000]");
  }
  if (!(shortcut_clearance >= 0.0) || !(shortcut_clearance <= inflation_radius)) {
    return Fail(why, "shortcut_clearance must be in [0, inflation_radius]");
  }
  if (!(shortcut_ratio >= 0.0 && shortcut_ratio <= 1.0)) return Fail(why, "shortcut_ratio must be in [0, 1]");
  if (!bounds_margin.allFinite() || (bounds_margin.array() < 0.0).any()) {
    return Fail(why, "bounds_margin must be non-negative and finite");
  }
  if (!(max_escape_distance >= 0.0) || !std::isfinite(max_escape_distance)) {
    return Fail(why, "max_escape_distance must be non-negative and finite");
  }
  if (!(heuristic_weight >= 1.0 && heuristic_weight <= 10.0)) {
    return Fail(why, "heuristic_weight must be in [1, 10]");
  }
  if (max_expansions <= 0) return Fail(why, "max_expansions must be positive");
  if (!(max_seconds > 0.0)) return Fail(why, "max_seconds must be positive");
  if (max_voxels <= 27 || max_voxels > std::numeric_limits<int>::max()) {
    return Fail(why, "max_voxels must be in (27, 2^31)");
  }
  return true;
}

core::Result<FrontEndMap> FrontEndMap::Build(const std::vector<Vec3>& obstacle_points,
                                             const FrontEndOptions& options,
                                             const std::vector<Vec3>& also_contain) {
  const Clock::time_point t0 = Clock::now();
  std::string why;
  if (!options.IsValid(&why)) return core::Status::InvalidArgument("front-end options: " + why);
  if (obstacle_points.empty()) return core::Status::InvalidArgument("front end: the obstacle cloud is empty");
  Vec3 lo = obstacle_points.front(), hi = obstacle_points.front();
  for (size_t n = 0; n < obstacle_points.size(); ++n) {
    if (!obstacle_points[n].allFinite()) {
      return core::Status::InvalidArgument("front end: obstacle point " + std::to_string(n) + " is not finite");
    }
    lo = lo.cwiseMin(obstacle_points[n]);
    hi = hi.cwiseMax(obstacle_points[n]);
  }
  for (const Vec3& p : also_contain) {
    if (!p.allFinite()) return core::Status::InvalidArgument("front end: a point to contain is not finite");
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  lo -= options.bounds_margin;
  hi += options.bounds_margin;

  const double v = options.voxel_size;
  Eigen::Vector3i dims;
  double padded = 1.0;
  for (int axis = 0; axis < 3; ++axis) {
    const double n = std::max(1.0, std::ceil((hi[axis] - lo[axis]) / v - 1e-9));
    padded *= n + 2.0;
    if (padded > static_cast<double>(options.max_voxels)) {
      return core::Status::InvalidArgument("front end: the grid box " + Format(lo) + " - " + Format(hi) +
                                           " needs more than max_voxels = " + std::to_string(options.max_voxels) +
                                           " voxels at voxel_size " + Format(v) +
                                           " (the box holds the whole scene, start and goal): crop the scene "
                                           "to where the robot flies (a scan's crop:, docs/task_format.md), "
                                           "or set front_end.voxel_size or max_voxels");
    }
    dims[axis] = static_cast<int>(n);
  }

  FrontEndMap map(obstacle_points, std::max(v, options.shortcut_clearance));
  map.options_ = options;
  map.lo_ = lo;
  map.dims_ = dims;
  map.hi_ = lo + dims.cast<double>() * v;
  const double r = options.inflation_radius;
  map.search_radius_ = std::sqrt(r * r + 0.75 * v * v);
  const double height = options.inflation_height > 0.0 ? options.inflation_height : r;
  map.search_height_ = std::sqrt(height * height + 0.75 * v * v);
  // Certifying a sub-segment of length v/2 from its midpoint's voxel needs
  // distances up to clearance + half diagonal + v/4 (see SubSegmentIsClear).
  map.distance_cap_ =
      std::max(map.search_radius_, options.shortcut_clearance + 0.5 * std::sqrt(3.0) * v + 0.25 * v) + 0.01 * v;

  for (int axis = 0; axis < 3; ++axis) map.block_dims_[axis] = (dims[axis] + 2 + kBlockEdge - 1) >> kBlockShift;
  map.block_slot_.assign(static_cast<size_t>(map.block_dims_.prod()), -1);
  const double cap = map.distance_cap_ / v;  // in voxels
  const float cap2 = static_cast<float>(cap * cap);
  // Distances are squared, in voxels, until the end.
  // Every voxel centre in the cube of half-width `cap` around each point
  // (values beyond the cap leave the initial cap^2 unchanged): no square
  // roots per column, and the inner loop vectorises. Squared offsets are
  // float; |offset| <= cap + 1 voxels, so their rounding stays far below the
  // 1e-6 relative margin applied at the end.
  const int reach = static_cast<int>(std::ceil(cap));
  std::vector<float> dx2(2 * reach + 2), dy2(2 * reach + 2), dz2(2 * reach + 2);
  auto offsets = [&](double centre, int n, int* first, int* last, std::vector<float>* squares) {
    *first = std::max(0, static_cast<int>(std::ceil(centre - cap)));
    *last = std::min(n - 1, static_cast<int>(std::floor(centre + cap)));
    for (int q = *first; q <= *last; ++q) {
      const double d = q - centre;
      (*squares)[q - *first] = static_cast<float>(d * d);
    }
  };
  // Runs along z within one block are contiguous: the last k of the run
  // that starts at k (padded k + 1).
  auto run_end = [](int k, int k_last) { return std::min(k_last, ((k + 1) | (kBlockEdge - 1)) - 1); };
  for (const Vec3& p : obstacle_points) {
    const Vec3 c = (p - lo) / v - Vec3::Constant(0.5);  // p in centre coordinates
    int i0, i1, j0, j1, k0, k1;
    offsets(c.x(), dims.x(), &i0, &i1, &dx2);
    offsets(c.y(), dims.y(), &j0, &j1, &dy2);
    offsets(c.z(), dims.z(), &k0, &k1, &dz2);
    for (int i = i0; i <= i1; ++i) {
      for (int j = j0; j <= j1; ++j) {
        const float dxy2 = dx2[i - i0] + dy2[j - j0];
        if (dxy2 >= cap2) continue;
        for (int k = k0; k <= k1;) {
          const int last = run_end(k, k1);
          const long slot = map.SlotFor(i + 1, j + 1, k + 1, cap2);  // (may grow the storage)
          float* row = map.distance_.data() + slot * kBlockVoxels + InBlock(i + 1, j + 1, k + 1);
          for (int q = k; q <= last; ++q) row[q - k] = std::min(row[q - k], dxy2 + dz2[q - k0]);
          k = last + 1;
        }
      }
    }
  }
  // Free: outside the ellipsoid of half-axes (search radius, search radius,
  // search height) around every point, a hair larger so that float
  // rounding never frees a voxel. A sphere reads it off the distances
  // (a voxel in no block is at the cap, beyond the search radius: free).
  const float search2 = static_cast<float>((map.search_radius_ / v) * (map.search_radius_ / v) * (1.0 + 1e-5));
  const bool sphere = map.search_height_ == map.search_radius_;
  // Without the sphere, a voxel the sphere would block is tight until the
  // ellipsoid blocks it below.
  for (size_t n = 0; n < map.distance_.size(); ++n) {
    map.blocked_[n] = map.distance_[n] < search2 ? (sphere ? kBlocked : kTight) : kFree;
  }
  if (!sphere) {
    // Along z in units of the radius: the ellipsoid becomes the sphere of
    // the search radius.
    const double stretch = map.search_radius_ / map.search_height_;
    const double radius_voxels = map.search_radius_ / v, height_voxels = map.search_height_ / v;
    for (const Vec3& p : obstacle_points) {
      const Vec3 c = (p - lo) / v - Vec3::Constant(0.5);
      const int i0 = std::max(0, static_cast<int>(std::ceil(c.x() - radius_voxels)));
      const int i1 = std::min(dims.x() - 1, static_cast<int>(std::floor(c.x() + radius_voxels)));
      const int j0 = std::max(0, static_cast<int>(std::ceil(c.y() - radius_voxels)));
      const int j1 = std::min(dims.y() - 1, static_cast<int>(std::floor(c.y() + radius_voxels)));
      const int k0 = std::max(0, static_cast<int>(std::ceil(c.z() - height_voxels)));
      const int k1 = std::min(dims.z() - 1, static_cast<int>(std::floor(c.z() + height_voxels)));
      for (int i = i0; i <= i1; ++i) {
        for (int j = j0; j <= j1; ++j) {
          const double dxy2 = (i - c.x()) * (i - c.x()) + (j - c.y()) * (j - c.y());
          if (dxy2 >= search2) continue;
          for (int k = k0; k <= k1; ++k) {
            const double dz = (k - c.z()) * stretch;
            if (dxy2 + dz * dz >= search2) continue;
            const long slot = map.SlotFor(i + 1, j + 1, k + 1, cap2);
            map.blocked_[slot * kBlockVoxels + InBlock(i + 1, j + 1, k + 1)] = kBlocked;
          }
        }
      }
    }
  }
  // The count is of the grid's own voxels: a block's voxels outside it
  // (the border, or past the last block's end) are never blocked here.
  map.num_blocked_ = 0;
  for (int bi = 0; bi < map.block_dims_.x(); ++bi) {
    for (int bj = 0; bj < map.block_dims_.y(); ++bj) {
      for (int bk = 0; bk < map.block_dims_.z(); ++bk) {
        const int slot = map.block_slot_[(static_cast<long>(bi) * map.block_dims_.y() + bj) * map.block_dims_.z() + bk];
        if (slot < 0) continue;
        for (int n = 0; n < kBlockVoxels; ++n) {
          const int pi = (bi << kBlockShift) | (n >> (2 * kBlockShift));
          const int pj = (bj << kBlockShift) | ((n >> kBlockShift) & (kBlockEdge - 1));
          const int pk = (bk << kBlockShift) | (n & (kBlockEdge - 1));
          if (!map.OnBorder(pi, pj, pk) && map.blocked_[static_cast<long>(slot) * kBlockVoxels + n] == kBlocked) {
            ++map.num_blocked_;
          }
        }
      }
    }
  }
  // Squared voxels -> metres, rounded down a little so float rounding never
  // overstates a distance; the cap stays a lower bound.
  auto metres = [v](float d2) { return static_cast<float>(std::sqrt(static_cast<double>(d2)) * v * (1.0 - 1e-6)); };
  for (float& d : map.distance_) d = metres(d);
  map.far_distance_ = metres(cap2);
  map.build_seconds_ = SecondsSince(t0);
  return map;
}

int FrontEndMap::SlotFor(int pi, int pj, int pk, float far) {
  int& slot = block_slot_[BlockOf(pi, pj, pk)];
  if (slot < 0) {
    slot = static_cast<int>(distance_.size() / kBlockVoxels);
    distance_.resize(distance_.size() + kBlockVoxels, far);
    blocked_.resize(blocked_.size() + kBlockVoxels, kFree);
  }
  return slot;
}

bool FrontEndMap::VoxelOf(const Vec3& p, Eigen::Vector3i* ijk) const {
  if (!p.allFinite() || (p.array() < lo_.array()).any() || (p.array() > hi_.array()).any()) return false;
  for (int axis = 0; axis < 3; ++axis) {
    const int n = static_cast<int>(std::floor((p[axis] - lo_[axis]) / options_.voxel_size));
    (*ijk)[axis] = std::clamp(n, 0, dims_[axis] - 1);
  }
  return true;
}

bool FrontEndMap::IsFree(const Vec3& p) const {
  Eigen::Vector3i ijk;
  return VoxelOf(p, &ijk) && BlockedAt(ijk.x() + 1, ijk.y() + 1, ijk.z() + 1) != kBlocked;
}

double FrontEndMap::DistanceLowerBound(const Vec3& p, double* upper) const {
  Eigen::Vector3i ijk;
  if (!VoxelOf(p, &ijk)) {
    *upper = std::numeric_limits<double>::infinity();
    return -std::numeric_limits<double>::infinity();
  }
  const double e = (p - Centre(ijk)).norm();
  const double d = DistanceAt(ijk.x() + 1, ijk.y() + 1, ijk.z() + 1);
  // Distances at or near the cap were clamped: no upper bound there.
  *upper = d < distance_cap_ * (1.0 - 1e-4) ? d + e : std::numeric_limits<double>::infinity();
  return d - e;
}

bool FrontEndMap::SubSegmentIsClear(const Vec3& a, const Vec3& b) const {
  const double clearance = options_.shortcut_clearance;
  const Vec3 box_lo = a.cwiseMin(b) - Vec3::Constant(clearance);
  const Vec3 box_hi = a.cwiseMax(b) + Vec3::Constant(clearance);
  const double c2 = clearance * clearance;
  bool clear = true;
  points_.VisitBox(box_lo, box_hi, [&](const Vec3& q) {
    if (clear && SquaredDistanceToSegment(q, a, b) < c2) clear = false;
  });
  return clear;
}

bool FrontEndMap::SegmentIsClear(const Vec3& a, const Vec3& b) const {
  Eigen::Vector3i ijk;
  if (!VoxelOf(a, &ijk) || !VoxelOf(b, &ijk)) return false;
  const double clearance = options_.shortcut_clearance;
  const double step = 0.5 * options_.voxel_size;
  const int pieces = std::max(1, static_cast<int>(std::ceil((b - a).norm() / step)));
  const double half = 0.5 * (b - a).norm() / pieces;
  // Pass 1: certify pieces from the distance grid (lower bound at the
  // midpoint minus half the piece), reject on a midpoint that is surely too
  // close; pass 2: exact point-to-segment distances for the rest.
  std::vector<int> uncertain;
  for (int n = 0; n < pieces; ++n) {
    const Vec3 mid = a + (b - a) * ((n + 0.5) / pieces);
    double upper;
    const double lower = DistanceLowerBound(mid, &upper);
    if (upper < clearance) return false;
    if (lower - half < clearance) uncertain.push_back(n);
  }
  for (int n : uncertain) {
    const Vec3 p0 = a + (b - a) * (static_cast<double>(n) / pieces);
    const Vec3 p1 = n + 1 == pieces ? b : Vec3(a + (b - a) * (static_cast<double>(n + 1) / pieces));
    if (!SubSegmentIsClear(p0, p1)) return false;
  }
  return true;
}

core::Result<FrontEndPath> FrontEndMap::FindPath(const Vec3& start, const Vec3& goal) const {
  const Clock::time_point t0 = Clock::now();
  FrontEndPath path;
  const double v = options_.voxel_size;

  // Start and goal voxels, escaping a blocked voxel to the nearest free one.
  auto endpoint_voxel = [&](const Vec3& p, const char* name, Eigen::Vector3i* out,
                            bool* escaped) -> core::Status {
    if (!p.allFinite()) return core::Status::InvalidArgument(std::string("front end: the ") + name + " is not finite");
    Eigen::Vector3i ijk;
    if (!VoxelOf(p, &ijk)) {
      return core::Status::InvalidArgument(std::string("front end: the ") + name + " " + Format(p) +
                                           " is outside the search box " + Format(lo_) + " - " + Format(hi_));
    }
    *escaped = BlockedAt(ijk.x() + 1, ijk.y() + 1, ijk.z() + 1) == kBlocked;
    if (!*escaped) {
      *out = ijk;
      return core::Status::Ok();
    }
    const int reach = static_cast<int>(std::ceil(options_.max_escape_distance / v)) + 1;
    double best = std::numeric_limits<double>::infinity();
    for (int i = std::max(0, ijk.x() - reach); i <= std::min(dims_.x() - 1, ijk.x() + reach); ++i) {
      for (int j = std::max(0, ijk.y() - reach); j <= std::min(dims_.y() - 1, ijk.y() + reach); ++j) {
        for (int k = std::max(0, ijk.z() - reach); k <= std::min(dims_.z() - 1, ijk.z() + reach); ++k) {
          if (BlockedAt(i + 1, j + 1, k + 1) == kBlocked) continue;
          const Eigen::Vector3i cand(i, j, k);
          const double d = (Centre(cand) - p).norm();
          if (d <= options_.max_escape_distance && d < best) {  // strict: the first (lowest index) wins ties
            best = d;
            *out = cand;
          }
        }
      }
    }
    if (!std::isfinite(best)) {
      return core::Status::InvalidArgument(std::string("front end: the ") + name + " " + Format(p) +
                                           " is within the inflation radius of the cloud and no free voxel lies "
                                           "within max_escape_distance = " +
                                           std::to_string(options_.max_escape_distance) + " m of it");
    }
    return core::Status::Ok();
  };
  Eigen::Vector3i s_ijk, g_ijk;
  QUADHAND_RETURN_IF_ERROR(endpoint_voxel(start, "start", &s_ijk, &path.start_escaped));
  QUADHAND_RETURN_IF_ERROR(endpoint_voxel(goal, "goal", &g_ijk, &path.goal_escaped));

  // A* over padded indices; the blocked border makes bounds checks unnecessary.
  const int sz = dims_.z() + 2, syz = (dims_.y() + 2) * sz;
  int offsets[26][3];
  long deltas[26];
  int costs[26];
  int n_off = 0;
  for (int di = -1; di <= 1; ++di) {
    for (int dj = -1; dj <= 1; ++dj) {
      for (int dk = -1; dk <= 1; ++dk) {
        if (di == 0 && dj == 0 && dk == 0) continue;
        offsets[n_off][0] = di;
        offsets[n_off][1] = dj;
        offsets[n_off][2] = dk;
        deltas[n_off] = static_cast<long>(di) * syz + static_cast<long>(dj) * sz + dk;
        const int order = di * di + dj * dj + dk * dk;
        costs[n_off] = order == 1 ? kCost1 : order == 2 ? kCost2 : kCost3;
        ++n_off;
      }
    }
  }
  int tight_costs[26];
  for (int d = 0; d < 26; ++d) {
    tight_costs[d] = static_cast<int>(std::lround(options_.tight_cost_factor * costs[d]));
  }
  thread_local SearchScratch scratch;
  const long grid_voxels = static_cast<long>(dims_.x() + 2) * (dims_.y() + 2) * (dims_.z() + 2);
  scratch.Prepare(grid_voxels, static_cast<long>(block_slot_.size()), kBlockVoxels);
  const std::uint32_t seen = scratch.current, closed = scratch.current + 1;
  const int source = static_cast<int>(Index(s_ijk.x(), s_ijk.y(), s_ijk.z()));
  const int target = static_cast<int>(Index(g_ijk.x(), g_ijk.y(), g_ijk.z()));
  const Eigen::Vector3i g_padded = g_ijk + Eigen::Vector3i::Ones();
  auto cell_of = [&](int node, int pi, int pj, int pk) {
    return scratch.Cell(node, BlockOf(pi, pj, pk), InBlock(pi, pj, pk));
  };
  auto decode = [&](int node, int* pi, int* pj, int* pk) {
    *pi = node / syz;
    *pj = (node / sz) % (dims_.y() + 2);
    *pk = node % sz;
  };

  OpenList open;
  open.Reserve(4096);
  {
    const long cell = cell_of(source, s_ijk.x() + 1, s_ijk.y() + 1, s_ijk.z() + 1);
    scratch.g[cell] = 0;
    scratch.parent[cell] = -1;
    scratch.stamp[cell] = seen;
  }
  const double weight = options_.heuristic_weight;
  auto weighted = [weight](int h) { return weight == 1.0 ? h : static_cast<int>(std::lround(weight * h)); };
  open.Push({weighted(Octile(s_ijk.x() - g_ijk.x(), s_ijk.y() - g_ijk.y(), s_ijk.z() - g_ijk.z())), 0, source});
  bool found = false;
  const Clock::time_point search_t0 = Clock::now();
  while (!open.empty()) {
    const OpenEntry top = open.Pop();
    int pi, pj, pk;
    decode(top.node, &pi, &pj, &pk);
    const long top_cell = cell_of(top.node, pi, pj, pk);
    if (scratch.stamp[top_cell] == closed || top.g > scratch.g[top_cell]) continue;
    scratch.stamp[top_cell] = closed;
    if (top.node == target) {
      found = true;
      break;
    }
    if (++path.expansions > options_.max_expansions) {
      return core::Status::Infeasible("front end: no path found within max_expansions = " +
                                      std::to_string(options_.max_expansions) + " A* expansions");
    }
    if ((path.expansions & 1023) == 0 && SecondsSince(search_t0) > options_.max_seconds) {
      return core::Status::Infeasible("front end: no path found within max_seconds = " +
                                      std::to_string(options_.max_seconds) + " s (" +
                                      std::to_string(path.expansions) + " expansions)");
    }
    for (int d = 0; d < 26; ++d) {
      const int ni = pi + offsets[d][0], nj = pj + offsets[d][1], nk = pk + offsets[d][2];
      if (OnBorder(ni, nj, nk)) continue;
      // (The block and the place in it serve the scratch's cell too.)
      const long block = BlockOf(ni, nj, nk);
      const int in_block = InBlock(ni, nj, nk);
      const unsigned char state = StateIn(block, in_block);
      if (state == kBlocked) continue;
      const int node = static_cast<int>(top.node + deltas[d]);
      const long cell = scratch.Cell(node, block, in_block);
      if (scratch.stamp[cell] == closed) continue;
      const int ng = top.g + (state == kTight ? tight_costs[d] : costs[d]);
      if (scratch.stamp[cell] == seen && ng >= scratch.g[cell]) continue;
      scratch.stamp[cell] = seen;
      scratch.g[cell] = ng;
      scratch.parent[cell] = top.node;
      const int h = Octile(ni - g_padded.x(), nj - g_padded.y(), nk - g_padded.z());
      open.Push({ng + weighted(h), ng, node});
    }
  }
  path.search_seconds = SecondsSince(search_t0);
  if (!found) {
    return core::Status::Infeasible("front end: no collision-free path from " + Format(start) + " to " +
                                    Format(goal) + " keeping " + std::to_string(options_.inflation_radius) +
                                    " m from the cloud inside the search box " + Format(lo_) + " - " +
                                    Format(hi_) + " (" + std::to_string(path.expansions) + " expansions)");
  }

  std::vector<Vec3> centres;
  for (int n = target; n >= 0;) {
    int pi, pj, pk;
    decode(n, &pi, &pj, &pk);
    centres.push_back(Centre(Eigen::Vector3i(pi - 1, pj - 1, pk - 1)));
    n = scratch.parent[cell_of(n, pi, pj, pk)];
  }
  std::reverse(centres.begin(), centres.end());
  std::vector<Vec3> raw;
  raw.reserve(centres.size() + 2);
  raw.push_back(start);
  raw.insert(raw.end(), centres.begin(), centres.end());
  raw.push_back(goal);
  path.raw = WithoutRepeats(raw);

  // Greedy shortcut: from each anchor, go as far along the raw path as the
  // straight segment stays clear. Neighbouring raw points are always kept
  // when nothing further is visible (the raw path is the fallback).
  const Clock::time_point shortcut_t0 = Clock::now();
  const std::vector<Vec3>& r = path.raw;
  path.shortcut.push_back(r.front());
  size_t anchor = 0;
  while (anchor + 1 < r.size()) {
    size_t next = anchor + 1;
    while (next + 1 < r.size() && SegmentIsClear(r[anchor], r[next + 1])) ++next;
    path.shortcut.push_back(r[next]);
    anchor = next;
  }
  path.shortcut_seconds = SecondsSince(shortcut_t0);
  path.seconds = SecondsSince(t0);
  return path;
}

core::Result<FrontEndPath> FindBasePath(const std::vector<Vec3>& obstacle_points, const Vec3& start,
                                        const Vec3& goal, const FrontEndOptions& options) {
  if (!start.allFinite() || !goal.allFinite()) {
    return core::Status::InvalidArgument("front end: the start or goal is not finite");
  }
  core::Result<FrontEndMap> map = FrontEndMap::Build(obstacle_points, options, {start, goal});
  if (!map.ok()) return map.status();
  return map->FindPath(start, goal);
}

double PathLength(const std::vector<Vec3>& path) {
  double length = 0.0;
  for (size_t n = 1; n < path.size(); ++n) length += (path[n] - path[n - 1]).norm();
  return length;
}

int PieceCountForPath(const std::vector<Vec3>& path, double piece_length, int min_pieces) {
  const std::vector<Vec3> clean = WithoutRepeats(path);
  const int segments = std::max(0, static_cast<int>(clean.size()) - 1);
  int count = std::max(min_pieces, segments);
  if (piece_length > 0.0) {
    const double by_length = std::ceil(PathLength(clean) / piece_length - 1e-9);
    if (by_length > count) count = static_cast<int>(std::min(by_length, 1e6));
  }
  return std::max(count, 1);
}

core::Status InitialGuessFromPath(const std::vector<Vec3>& path, int num_pieces, double cruise_speed,
                                  double acceleration, MatX* waypoints, VecX* durations) {
  if (waypoints == nullptr || durations == nullptr) {
    return core::Status::InvalidArgument("initial guess: null output");
  }
  if (path.size() < 2) return core::Status::InvalidArgument("initial guess: the path needs at least two points");
  for (const Vec3& p : path) {
    if (!p.allFinite()) return core::Status::InvalidArgument("initial guess: the path has a non-finite point");
  }
  if (!(cruise_speed > 0.0) || !std::isfinite(cruise_speed) || !(acceleration > 0.0) ||
      !std::isfinite(acceleration)) {
    return core::Status::InvalidArgument("initial guess: cruise_speed and acceleration must be positive and finite");
  }
  if (num_pieces < 1) return core::Status::InvalidArgument("initial guess: num_pieces must be at least 1");
  const std::vector<Vec3> clean = WithoutRepeats(path);
  const int segments = static_cast<int>(clean.size()) - 1;
  if (segments == 0) {
    waypoints->resize(3, num_pieces - 1);
    for (int n = 0; n < num_pieces - 1; ++n) waypoints->col(n) = clean.front();
    durations->setConstant(num_pieces, 0.1);
    return core::Status::Ok();
  }
  if (num_pieces < segments) {
    return core::Status::InvalidArgument("initial guess: num_pieces = " + std::to_string(num_pieces) +
                                         " is fewer than the path's " + std::to_string(segments) +
                                         " segments (every corner must be a waypoint; see PieceCountForPath)");
  }
  std::vector<double> lengths(segments);
  for (int m = 0; m < segments; ++m) lengths[m] = (clean[m + 1] - clean[m]).norm();
  std::vector<int> counts(segments, 1);
  for (int extra = num_pieces - segments; extra > 0; --extra) {
    int best = 0;
    for (int m = 1; m < segments; ++m) {
      if (lengths[m] / counts[m] > lengths[best] / counts[best]) best = m;
    }
    ++counts[best];
  }

  // Piece boundaries (points and arc lengths).
  std::vector<Vec3> points{clean.front()};
  std::vector<double> arc{0.0};
  for (int m = 0; m < segments; ++m) {
    for (int q = 1; q <= counts[m]; ++q) {
      const double t = static_cast<double>(q) / counts[m];
      points.push_back(q == counts[m] ? clean[m + 1] : Vec3(clean[m] + t * (clean[m + 1] - clean[m])));
      arc.push_back(arc.back() + lengths[m] / counts[m]);
    }
  }
  const double total = arc.back();
  // Trapezoidal profile: time to reach arc length s (rest to rest).
  const double ramp = std::min(0.5 * total, 0.5 * cruise_speed * cruise_speed / acceleration);
  const double peak = std::sqrt(2.0 * acceleration * ramp);  // = cruise_speed unless the path is short
  const double t_ramp = peak / acceleration;
  const double t_total = 2.0 * t_ramp + (total - 2.0 * ramp) / peak;
  auto time_at = [&](double s) {
    if (s <= ramp) return std::sqrt(2.0 * std::max(0.0, s) / acceleration);
    if (s <= total - ramp) return t_ramp + (s - ramp) / peak;
    return t_total - std::sqrt(2.0 * std::max(0.0, total - s) / acceleration);
  };
  waypoints->resize(3, num_pieces - 1);
  durations->resize(num_pieces);
  for (int n = 0; n < num_pieces; ++n) {
    if (n + 1 < num_pieces) waypoints->col(n) = points[n + 1];
    const double t1 = n + 1 == num_pieces ? t_total : time_at(arc[n + 1]);
    (*durations)[n] = std::max(t1 - time_at(arc[n]), 1e-6);
  }
  return core::Status::Ok();
}

}  // namespace quadhand::planner
