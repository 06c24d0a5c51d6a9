#include "quadhand/perception/rolling_map.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <thread>
#include <unordered_map>
#include <unordered_set>

namespace quadhand::perception {
namespace {

bool Fail(std::string* why, const std::string& message) {
  if (why != nullptr) *why = message;
  return false;
}

bool In(double x, double lo, double hi) { return std::isfinite(x) && x >= lo && x <= hi; }

// Log-odds are kept as 8-bit integers of this many units per nat, clamped
// as OctoMap clamps them (probabilities 0.1192 and 0.971: -2 and 3.5 nats),
// so a voxel seen often changes its mind in a bounded number of frames.
constexpr double kUnitsPerNat = 20.0;
constexpr int kClampLow = -40, kClampHigh = 70;
constexpr std::int8_t kUnknown = -128;
// A voxel's mark byte: this frame's end voxel and crossed voxel (cleared
// after each frame), and whether its occupancy comes from the prior map
// alone (kept until a return ends in it or the window forgets it).
constexpr std::uint8_t kEndMark = 1, kCrossedMark = 2, kFrameMarks = kEndMark | kCrossedMark, kPriorMark = 4;
// The prior map's points are kept by chunks of this many voxels a side, so
// that the slabs a window's move brings in find theirs in a few look-ups.
constexpr int kPriorChunkShift = 4;
// A thread is started per this many rays at least: fewer are walked sooner
// than a thread starts.
constexpr size_t kRaysPerThread = 2000;

int LogOddsUnits(double probability) {
  return static_cast<int>(std::lround(std::log(probability / (1.0 - probability)) * kUnitsPerNat));
}

}  // namespace

bool RollingMapOptions::IsValid(std::string* why) const {
  if (!In(resolution, 0.005, 5.0)) return Fail(why, "resolution must be in [0.005, 5] m");
  if (!window_half_extent.allFinite() || (window_half_extent.array() < resolution).any() ||
      (window_half_extent.array() > 1e4).any()) {
    return Fail(why, "window_half_extent must be in [resolution, 10000] m on every axis");
  }
  // The window is a dense ring of voxels: 2^28 of them at most (256 MB).
  const Eigen::Array3d cells = (2.0 * window_half_extent.array() / resolution).ceil() + 1.0;
  if (cells.prod() > static_cast<double>(1 << 28)) {
    return Fail(why, "the window holds more than 2^28 voxels: raise resolution or shrink window_half_extent");
  }
  if (!In(max_range, resolution, 1e4)) return Fail(why, "max_range must be in [resolution, 10000] m");
  if (!(probability_hit > 0.5 && probability_hit < 0.99)) return Fail(why, "probability_hit must be in (0.5, 0.99)");
  if (!(probability_miss > 0.01 && probability_miss < 0.5)) return Fail(why, "probability_miss must be in (0.01, 0.5)");
  if (!(occupied_threshold > 0.12 && occupied_threshold < 0.97)) {
    return Fail(why, "occupied_threshold must be in (0.12, 0.97)");
  }
  if (max_points_per_voxel < 1 || max_points_per_voxel > 1000) return Fail(why, "max_points_per_voxel must be in [1, 1000]");
  if (ray_threads < 1 || ray_threads > 64) return Fail(why, "ray_threads must be in [1, 64]");
  if (stop_ray_after_crossed < 0 || stop_ray_after_crossed > 1000) {
    return Fail(why, "stop_ray_after_crossed must be in [0, 1000] (0: walk every ray whole)");
  }
  return true;
}

// A frame's end voxels by cell: open addressing, linear probing, cleared
// per frame. Keyed by the ring's cell (unique within the window) and
// holding the voxel's slot in the frame's lists; much cheaper per return
// than a node-based table.
class FrameVoxelTable {
 public:
  // The slot stored for `cell`, or `slot` stored for it now (second: true).
  std::pair<int, bool> FindOrInsert(size_t cell, int slot) {
    if (2 * (used_ + 1) > keys_.size()) Grow();
    size_t at = Hash(cell);
    while (true) {
      if (keys_[at] == kEmpty) {
        keys_[at] = cell;
        slots_[at] = slot;
        ++used_;
        return {slot, true};
      }
      if (keys_[at] == cell) return {slots_[at], false};
      at = (at + 1) & mask_;
    }
  }
  void Clear() {
    if (used_ == 0) return;
    std::fill(keys_.begin(), keys_.end(), kEmpty);
    used_ = 0;
  }

 private:
  static constexpr size_t kEmpty = std::numeric_limits<size_t>::max();
  size_t Hash(size_t cell) const { return (cell * 0x9E3779B97F4A7C15ull) >> shift_; }
  void Grow() {
    std::vector<size_t> keys = std::move(keys_);
    std::vector<int> slots = std::move(slots_);
    const size_t capacity = std::max<size_t>(1024, 2 * keys.size());
    keys_.assign(capacity, kEmpty);
    slots_.assign(capacity, 0);
    mask_ = capacity - 1;
    shift_ = 64 - static_cast<int>(std::log2(static_cast<double>(capacity)) + 0.5);
    used_ = 0;
    for (size_t i = 0; i < keys.size(); ++i) {
      if (keys[i] != kEmpty) FindOrInsert(keys[i], slots[i]);
    }
  }
  std::vector<size_t> keys_;
  std::vector<int> slots_;
  size_t used_ = 0, mask_ = 0;
  int shift_ = 64;
};

// The voxels of a box and which of them are free.
struct FreeBox {
  Eigen::Vector3i first = Eigen::Vector3i::Zero(), size = Eigen::Vector3i::Zero();
  std::vector<std::uint8_t> free;
};

// The window is a dense ring of voxels over global voxel indices
// [low, low + dims): voxel (i, j, k) lives in cell (i mod nx, j mod ny,
// k mod nz), so moving the window clears only the slabs that leave it.
struct RollingMap::Impl {
  explicit Impl(const RollingMapOptions& o) : options(o) {
    for (int a = 0; a < 3; ++a) dims[a] = static_cast<int>(std::ceil(2.0 * o.window_half_extent[a] / o.resolution)) + 1;
    cells.assign(static_cast<size_t>(dims.x()) * dims.y() * dims.z(), Voxel{});
    hit = LogOddsUnits(o.probability_hit);
    miss = LogOddsUnits(o.probability_miss);
    threshold = LogOddsUnits(o.occupied_threshold);
    occupied_floor = static_cast<std::int8_t>(std::min(threshold + 1, static_cast<int>(kClampHigh)));
    low = LowFor(Vec3::Zero());
    swept_low = low;
  }

  Eigen::Vector3i LowFor(const Vec3& c) const {
    Eigen::Vector3i l;
    for (int a = 0; a < 3; ++a) l[a] = static_cast<int>(std::floor(c[a] / options.resolution)) - dims[a] / 2;
    return l;
  }
  Eigen::Vector3i VoxelOf(const Vec3& p) const {
    return (p / options.resolution).array().floor().cast<int>().matrix();
  }
  bool Inside(const Eigen::Vector3i& v) const {
    return ((v - low).array() >= 0).all() && ((v - low).array() < dims.array()).all();
  }
  // Whether the segment from `from` to `to` crosses the window's box, and
  // where it enters it (the fraction of the way along, in [0, 1]).
  bool CrossesWindow(const Vec3& from, const Vec3& to, double* t_in = nullptr) const {
    const double res = options.resolution;
    const Vec3 d = to - from;
    double enter = 0.0, leave = 1.0;
    for (int a = 0; a < 3; ++a) {
      const double lo = low[a] * res, hi = (low[a] + dims[a]) * res;
      if (d[a] == 0.0) {
        if (from[a] < lo || from[a] >= hi) return false;
        continue;
      }
      const double t0 = (lo - from[a]) / d[a], t1 = (hi - from[a]) / d[a];
      enter = std::max(enter, std::min(t0, t1));
      leave = std::min(leave, std::max(t0, t1));
    }
    if (t_in != nullptr) *t_in = enter;
    return enter <= leave;
  }
  static int Mod(int a, int n) { return ((a % n) + n) % n; }
  size_t CellOfRing(int x, int y, int z) const {
    return (static_cast<size_t>(x) * dims.y() + y) * dims.z() + z;
  }
  size_t Cell(const Eigen::Vector3i& v) const {
    return CellOfRing(Mod(v.x(), dims.x()), Mod(v.y(), dims.y()), Mod(v.z(), dims.z()));
  }
  // The free voxels of the box [lo, hi] in whole voxels (1 free, 0 not;
  // x, then y, then z). Called at every replan over a box of about half a
  // million voxels: the ring's cell of each box coordinate is worked out
  // once per axis (-1 outside the window).
  FreeBox FreeOfBox(const Vec3& lo, const Vec3& hi) const {
    FreeBox box;
    box.first = VoxelOf(lo);
    box.size = VoxelOf(hi) - box.first + Eigen::Vector3i::Ones();
    std::array<std::vector<int>, 3> ring;
    for (int a = 0; a < 3; ++a) {
      ring[a].resize(static_cast<size_t>(box.size[a]));
      for (int r = 0; r < box.size[a]; ++r) {
        const int v = box.first[a] + r - low[a];
        ring[a][static_cast<size_t>(r)] = v >= 0 && v < dims[a] ? Mod(box.first[a] + r, dims[a]) : -1;
      }
    }
    const size_t stride_y = static_cast<size_t>(box.size.z()), stride_x = static_cast<size_t>(box.size.y()) * stride_y;
    box.free.assign(stride_x * static_cast<size_t>(box.size.x()), 0);
    for (int i = 0; i < box.size.x(); ++i) {
      const int ci = ring[0][static_cast<size_t>(i)];
      if (ci < 0) continue;
      for (int j = 0; j < box.size.y(); ++j) {
        const int cj = ring[1][static_cast<size_t>(j)];
        if (cj < 0) continue;
        const size_t row = CellOfRing(ci, cj, 0), local = static_cast<size_t>(i) * stride_x + j * stride_y;
        for (int k = 0; k < box.size.z(); ++k) {
          const int ck = ring[2][static_cast<size_t>(k)];
          if (ck < 0) continue;
          const std::int8_t value = cells[row + static_cast<size_t>(ck)].value;
          if (value != kUnknown && value <= threshold) box.free[local + static_cast<size_t>(k)] = 1;
        }
      }
    }
    return box;
  }
  static std::int64_t Key(const Eigen::Vector3i& v) {
    return (static_cast<std::int64_t>(v.x() & 0x1fffff) << 42) | (static_cast<std::int64_t>(v.y() & 0x1fffff) << 21) |
           static_cast<std::int64_t>(v.z() & 0x1fffff);
  }
  bool Occupied(const Eigen::Vector3i& v) const {
    if (!Inside(v)) return false;
    const std::int8_t value = cells[Cell(v)].value;
    return value != kUnknown && value > threshold;
  }
  void Update(size_t cell, int delta) {
    const int before = cells[cell].value == kUnknown ? 0 : cells[cell].value;
    cells[cell].value = static_cast<std::int8_t>(std::clamp(before + delta, kClampLow, kClampHigh));
  }
  // The frame's returns kept in their voxels' raw points (each voxel's in
  // the frame's order: the first max_points_per_voxel, then each one after
  // replacing the frame's slot), one table look-up per end voxel rather
  // than per return: grouped by a counting sort on the voxels' slots.
  void KeepReturns(const std::vector<Vec3>& points, size_t cap) {
    const size_t voxels = end_voxels.size();
    group_start.assign(voxels + 1, 0);
    for (const auto& [slot, index] : point_slots) ++group_start[static_cast<size_t>(slot) + 1];
    for (size_t k = 0; k < voxels; ++k) group_start[k + 1] += group_start[k];
    grouped.resize(point_slots.size());
    group_fill.assign(group_start.begin(), group_start.end() - 1);
    for (const auto& [slot, index] : point_slots) grouped[group_fill[static_cast<size_t>(slot)]++] = index;
    const size_t replaced = static_cast<size_t>(frames) % cap;
    for (size_t k = 0; k < voxels; ++k) {
      std::vector<Vec3>& kept = raw[Key(end_voxels[k])];
      for (int g = group_start[k]; g < group_start[k + 1]; ++g) {
        const Vec3& p = points[static_cast<size_t>(grouped[static_cast<size_t>(g)])];
        if (kept.size() < cap) {
          kept.push_back(p);
        } else {
          kept[replaced] = p;
        }
      }
    }
    point_slots.clear();
    frame_voxels.Clear();
  }
  // A return ended in the voxel this frame.
  void Hit(size_t cell) {
    cells[cell].mark &= static_cast<std::uint8_t>(~kPriorMark);
    Update(cell, hit);
    if (options.returns_stay_occupied) cells[cell].value = std::max(cells[cell].value, occupied_floor);
  }
  // A ray crossed the voxel without ending there.
  void Miss(size_t cell) {
    // A voxel occupied by the prior alone is no surer than an unknown one:
    // a ray through it frees it as it would free unknown space.
    if (options.returns_stay_occupied && cells[cell].value != kUnknown && cells[cell].value > threshold &&
        (cells[cell].mark & kPriorMark) == 0) {
      return;
    }
    Update(cell, miss);
  }
  // A ray crossed the voxel: missed once this frame, unless it is an end
  // voxel. With several threads walking rays, the one whose compare-and-swap
  // marks the voxel owns it for the frame: only it writes the voxel's value.
  // True when an earlier ray of this frame had crossed it already.
  template <bool kShared>
  bool Cross(size_t cell, std::vector<size_t>* crossed) {
    std::uint8_t& mark = cells[cell].mark;
    if constexpr (kShared) {
      std::uint8_t seen = __atomic_load_n(&mark, __ATOMIC_RELAXED);
      do {
        if ((seen & kFrameMarks) != 0) return (seen & kCrossedMark) != 0;
      } while (!__atomic_compare_exchange_n(&mark, &seen, static_cast<std::uint8_t>(seen | kCrossedMark), false,
                                            __ATOMIC_RELAXED, __ATOMIC_RELAXED));
    } else {
      if ((mark & kFrameMarks) != 0) return (mark & kCrossedMark) != 0;
      mark |= kCrossedMark;
    }
    crossed->push_back(cell);
    Miss(cell);
    return false;
  }
  // One line's walk through the voxels of a ring of `size` voxels a side
  // (cell strides `cell_stride`), from the voxel `voxel` holding `from`
  // along `d` (Amanatides and Woo). `rel` is the voxel's place in the window,
  // for the callers that test it.
  struct VoxelWalk {
    int step[3], rel[3], ring[3], size[3];
    double t_max[3], t_delta[3];
    // The cell moves by a stride a step, and back by the ring's span where
    // the ring wraps: no multiplication a step.
    std::ptrdiff_t forward[3], wrap[3], cell;

    VoxelWalk(const Vec3& from, const Eigen::Vector3i& voxel, const Vec3& d, double res, const Eigen::Vector3i& low,
              const int ring_size[3], const std::ptrdiff_t cell_stride[3]) {
      cell = 0;
      for (int a = 0; a < 3; ++a) {
        size[a] = ring_size[a];
        step[a] = d[a] > 0.0 ? 1 : (d[a] < 0.0 ? -1 : 0);
        rel[a] = voxel[a] - low[a];
        ring[a] = Mod(voxel[a], size[a]);
        cell += ring[a] * cell_stride[a];
        forward[a] = step[a] * cell_stride[a];
        wrap[a] = -step[a] * static_cast<std::ptrdiff_t>(size[a] - 1) * cell_stride[a];
        if (step[a] == 0) {
          t_max[a] = t_delta[a] = std::numeric_limits<double>::infinity();
          continue;
        }
        const double boundary = (voxel[a] + (step[a] > 0 ? 1 : 0)) * res;
        t_max[a] = (boundary - from[a]) / d[a];
        t_delta[a] = res / std::abs(d[a]);
      }
    }
    // One step, along the axis whose boundary comes first.
    void Advance() {
      const int axis = t_max[0] < t_max[1] ? (t_max[0] < t_max[2] ? 0 : 2) : (t_max[1] < t_max[2] ? 1 : 2);
      rel[axis] += step[axis];
      ring[axis] += step[axis];
      if (ring[axis] == size[axis]) {
        ring[axis] = 0;
        cell += wrap[axis];
      } else if (ring[axis] < 0) {
        ring[axis] = size[axis] - 1;
        cell += wrap[axis];
      } else {
        cell += forward[axis];
      }
      t_max[axis] += t_delta[axis];
    }
  };
  // Walks rays first, first + stride, ... (Amanatides and Woo), in plain
  // integers: the voxel's place in the window (for the inside test) and in
  // the ring (for its cell) move with it, no division a step. A ray with
  // both ends inside the window is walked back from its end, and stops
  // after options.stop_ray_after_crossed voxels in a row that earlier rays
  // of the frame crossed (RollingMapOptions).
  template <bool kShared>
  void WalkRays(const std::vector<std::pair<Vec3, bool>>& rays, size_t first, size_t stride, const Vec3& origin,
                std::vector<size_t>* crossed);
  // The prior's chunk holding voxel v, and its key.
  static Eigen::Vector3i ChunkOf(const Eigen::Vector3i& v) {
    return Eigen::Vector3i(v.x() >> kPriorChunkShift, v.y() >> kPriorChunkShift, v.z() >> kPriorChunkShift);
  }
  static std::int64_t ChunkKey(const Eigen::Vector3i& v) { return Key(ChunkOf(v)); }
  // The prior's points in the voxels of [first, last] (inclusive, in
  // voxels; the part inside the window): each unknown voxel holding one
  // becomes occupied by the prior alone, with its points kept. Voxels the
  // sensor has seen keep what it saw.
  void SeedPrior(const Eigen::Vector3i& first, const Eigen::Vector3i& last) {
    const Eigen::Vector3i lo = first.cwiseMax(low), hi = last.cwiseMin(low + dims - Eigen::Vector3i::Ones());
    if ((hi.array() < lo.array()).any() || prior.empty()) return;
    const size_t cap = static_cast<size_t>(options.max_points_per_voxel);
    const Eigen::Vector3i chunk_lo = ChunkOf(lo), chunk_hi = ChunkOf(hi);
    for (int i = chunk_lo.x(); i <= chunk_hi.x(); ++i) {
      for (int j = chunk_lo.y(); j <= chunk_hi.y(); ++j) {
        for (int k = chunk_lo.z(); k <= chunk_hi.z(); ++k) {
          const auto found = prior.find(Key(Eigen::Vector3i(i, j, k)));
          if (found == prior.end()) continue;
          for (const Vec3& p : found->second) {
            const Eigen::Vector3i v = VoxelOf(p);
            if ((v.array() < lo.array()).any() || (v.array() > hi.array()).any()) continue;
            Voxel& voxel = cells[Cell(v)];
            const bool held_by_prior = (voxel.mark & kPriorMark) != 0 && voxel.value > threshold;
            if (voxel.value != kUnknown && !held_by_prior) continue;  // seen by the sensor
            std::vector<Vec3>& kept = raw[Key(v)];
            if (voxel.value == kUnknown) {
              voxel.value = occupied_floor;
              voxel.mark = kPriorMark;
              kept.clear();  // what a voxel forgotten here before kept
            }
            if (kept.size() < cap) kept.push_back(p);
          }
        }
      }
    }
  }

  RollingMapOptions options;
  Eigen::Vector3i dims = Eigen::Vector3i::Ones(), low = Eigen::Vector3i::Zero();
  Vec3 centre = Vec3::Zero();
  // A voxel's log-odds, and a frame's mark beside it (one cache line for
  // both: the ray walk is bound by memory): 1, an end voxel; 2, crossed;
  // cleared after the frame, so that each voxel is updated once per frame
  // and an end voxel is never also missed.
  struct Voxel {
    std::int8_t value = kUnknown;
    std::uint8_t mark = 0;
  };
  std::vector<Voxel> cells;
  std::vector<size_t> touched;
  std::vector<Eigen::Vector3i> end_voxels;  // the end voxels of touched's first entries, this frame
  std::vector<Vec3> newly_blocked;          // NewlyBlocked()
  int hit = 0, miss = 0, threshold = 0;
  std::int8_t occupied_floor = 0;  // the least occupied value (returns_stay_occupied)
  std::unordered_map<std::int64_t, std::vector<Vec3>> raw;  // by voxel key: the newest returns there
  // This frame's end voxels (cell -> slot in touched and end_voxels), each
  // return's slot and index, and KeepReturns' grouping of them.
  FrameVoxelTable frame_voxels;
  std::vector<std::pair<int, int>> point_slots;
  std::vector<int> group_start, group_fill, grouped;
  // The prior map (SetPrior): its finite points by chunk (ChunkKey).
  std::unordered_map<std::int64_t, std::vector<Vec3>> prior;
  size_t prior_points = 0;
  size_t swept_size = 1024;  // raw's size after its last sweep (MoveWindow),
  Eigen::Vector3i swept_low = Eigen::Vector3i::Zero();  // and the window's low then
  long frames = 0;
  long dropped = 0;
};

RollingMap::RollingMap(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
RollingMap::~RollingMap() = default;

core::Result<std::unique_ptr<RollingMap>> RollingMap::Create(const RollingMapOptions& options) {
  if (std::string why; !options.IsValid(&why)) return core::Status::InvalidArgument("rolling map: " + why);
  return std::unique_ptr<RollingMap>(new RollingMap(std::make_unique<Impl>(options)));
}

core::Status RollingMap::Insert(const std::vector<Vec3>& points, const Vec3& origin, const std::vector<Vec3>& misses) {
  Impl& m = *impl_;
  if (!origin.allFinite()) return core::Status::InvalidArgument("rolling map: a frame's sensor origin is not finite");
  const double res = m.options.resolution;
  const size_t cap = static_cast<size_t>(m.options.max_points_per_voxel);
  // End voxels first: each once, and never missed in this frame.
  std::vector<std::pair<Vec3, bool>> rays;  // the ray's far end, and whether it ends in a return
  rays.reserve(points.size());
  std::unordered_set<std::int64_t> beyond;  // the end voxels outside the window, this frame
  const bool origin_inside = m.Inside(m.VoxelOf(origin));
  for (const Vec3& p : points) {
    if (!p.allFinite()) {
      ++m.dropped;
      continue;
    }
    const double range = (p - origin).norm();
    if (range > m.options.max_range) {
      const Vec3 end = origin + (p - origin) * (m.options.max_range / range);
      if (origin_inside || m.CrossesWindow(origin, end)) rays.emplace_back(end, false);
      continue;
    }
    const Eigen::Vector3i v = m.VoxelOf(p);
    if (!m.Inside(v)) {
      // Beyond the window: its ray may still cross the window's voxels. One
      // ray per end voxel, as inside it.
      if ((origin_inside || m.CrossesWindow(origin, p)) && beyond.insert(Impl::Key(v)).second) {
        rays.emplace_back(p, false);
      }
      continue;
    }
    const size_t cell = m.Cell(v);
    const auto [slot, first] = m.frame_voxels.FindOrInsert(cell, static_cast<int>(m.touched.size()));
    m.point_slots.emplace_back(slot, static_cast<int>(&p - points.data()));
    if (!first) continue;  // this voxel's ray is cast already
    m.cells[cell].mark |= kEndMark;
    m.touched.push_back(cell);
    m.end_voxels.push_back(v);
    rays.emplace_back(p, true);
  }
  m.KeepReturns(points, cap);
  for (const Vec3& p : misses) {
    if (!p.allFinite()) {
      ++m.dropped;
      continue;
    }
    const double range = (p - origin).norm();
    const Vec3 end = range > m.options.max_range ? origin + (p - origin) * (m.options.max_range / range) : p;
    if (origin_inside || m.CrossesWindow(origin, end)) rays.emplace_back(end, false);
  }
  m.newly_blocked.clear();
  for (size_t i = 0; i < m.touched.size(); ++i) {
    const size_t cell = m.touched[i];
    const std::int8_t before = m.cells[cell].value;
    m.Hit(cell);
    if (before != kUnknown && before <= m.threshold && m.cells[cell].value > m.threshold) {
      m.newly_blocked.push_back((m.end_voxels[i].cast<double>().array() + 0.5).matrix() * res);
    }
  }
  m.end_voxels.clear();
  // Each ray's voxels before its end. Threads share the rays round-robin
  // (near and far rays alike) when there are enough to be worth a thread.
  const size_t threads =
      std::min<size_t>(static_cast<size_t>(m.options.ray_threads), std::max<size_t>(1, rays.size() / kRaysPerThread));
  if (threads <= 1) {
    m.WalkRays<false>(rays, 0, 1, origin, &m.touched);
  } else {
    std::vector<std::vector<size_t>> crossed(threads);
    std::vector<std::thread> helpers;
    for (size_t k = 1; k < threads; ++k) {
      helpers.emplace_back([&, k] { m.WalkRays<true>(rays, k, threads, origin, &crossed[k]); });
    }
    m.WalkRays<true>(rays, 0, threads, origin, &crossed[0]);
    for (std::thread& helper : helpers) helper.join();
    for (const std::vector<size_t>& cells : crossed) m.touched.insert(m.touched.end(), cells.begin(), cells.end());
  }
  for (size_t cell : m.touched) m.cells[cell].mark &= kPriorMark;
  m.touched.clear();
  ++m.frames;
  return core::Status::Ok();
}

template <bool kShared>
void RollingMap::Impl::WalkRays(const std::vector<std::pair<Vec3, bool>>& rays, size_t first, size_t stride,
                                const Vec3& origin, std::vector<size_t>* crossed) {
  const double res = options.resolution;
  const int nx = dims.x(), ny = dims.y(), nz = dims.z();
  const Eigen::Vector3i start = VoxelOf(origin);
  const int size[3] = {nx, ny, nz};
  const std::ptrdiff_t cell_stride[3] = {static_cast<std::ptrdiff_t>(ny) * nz, nz, 1};
  const bool origin_inside = Inside(start);
  auto interior = [&](const Eigen::Vector3i& v) {
    return ((v - low).array() >= 1).all() && ((v - low).array() < dims.array() - 1).all();
  };
  const bool origin_interior = interior(start);
  const int stop_after = options.stop_ray_after_crossed;
  for (size_t r = first; r < rays.size(); r += stride) {
    const auto& [end, returned] = rays[r];
    const Eigen::Vector3i last = VoxelOf(end);
    if (origin_interior && interior(last)) {
      // Both ends a voxel inside the window: so is every voxel the walk
      // visits (it stays in the box of its two ends but for one step past
      // an end where rounding breaks a near tie, and the window is a box),
      // so no test a step. Walked back from the end: the voxels near the
      // sensor, which every ray crosses, come last, where the walk may stop.
      const int steps = std::abs(last.x() - start.x()) + std::abs(last.y() - start.y()) + std::abs(last.z() - start.z());
      VoxelWalk walk(end, last, origin - end, res, low, size, cell_stride);
      int in_a_row = 0;
      auto cross = [&](std::ptrdiff_t cell) {
        if (Cross<kShared>(static_cast<size_t>(cell), crossed)) return stop_after > 0 && ++in_a_row >= stop_after;
        in_a_row = 0;
        return false;
      };
      if (!returned && cross(walk.cell)) continue;  // a ray cut at max_range: its end is crossed, not hit
      for (int n = 0; n < steps; ++n) {
        walk.Advance();
        if (cross(walk.cell)) break;
      }
      continue;
    }
    // A sensor outside the window (a small window about a place the vehicle
    // looks at from afar): the walk starts where the ray enters the window,
    // or not at all. The voxels skipped lie outside it, where nothing is done.
    const Vec3 d = end - origin;
    Vec3 from = origin;
    Eigen::Vector3i first_voxel = start;
    if (!origin_inside) {
      double t_in = 0.0;
      if (!CrossesWindow(origin, end, &t_in)) continue;
      from = origin + t_in * d;
      first_voxel = VoxelOf(from);
    }
    // At most the voxels a straight line crosses between the two; a line
    // leaves a box once, so the walk ends where it leaves the window.
    const int steps = std::abs(last.x() - first_voxel.x()) + std::abs(last.y() - first_voxel.y()) +
                      std::abs(last.z() - first_voxel.z());
    VoxelWalk walk(from, first_voxel, d, res, low, size, cell_stride);
    bool entered = false;
    for (int n = 0; n < steps; ++n) {
      if (static_cast<unsigned>(walk.rel[0]) < static_cast<unsigned>(nx) &&
          static_cast<unsigned>(walk.rel[1]) < static_cast<unsigned>(ny) &&
          static_cast<unsigned>(walk.rel[2]) < static_cast<unsigned>(nz)) {
        Cross<kShared>(static_cast<size_t>(walk.cell), crossed);
        entered = true;
      } else if (entered) {
        break;
      }
      walk.Advance();
    }
    if (!returned && Inside(last)) Cross<kShared>(Cell(last), crossed);  // a ray cut at max_range: crossed, not hit
  }
}

void RollingMap::MoveWindow(const Vec3& centre) {
  Impl& m = *impl_;
  if (!centre.allFinite()) return;
  const Eigen::Vector3i low = m.LowFor(centre);
  const Eigen::Vector3i old_low = m.low;
  // The voxels of the old window outside the new one are cleared: slab by
  // slab along each axis (all of it when the shift is the window's size).
  for (int a = 0; a < 3; ++a) {
    const int shift = low[a] - m.low[a];
    if (shift == 0) continue;
    const int count = std::min(std::abs(shift), m.dims[a]);
    for (int s = 0; s < count; ++s) {
      // The global index leaving along axis a.
      const int leaving = shift > 0 ? m.low[a] + s : m.low[a] + m.dims[a] - 1 - s;
      const int ring = Impl::Mod(leaving, m.dims[a]);
      const int b = (a + 1) % 3, c = (a + 2) % 3;
      for (int i = 0; i < m.dims[b]; ++i) {
        for (int j = 0; j < m.dims[c]; ++j) {
          Eigen::Vector3i idx;
          idx[a] = ring;
          idx[b] = i;
          idx[c] = j;
          Impl::Voxel& voxel = m.cells[m.CellOfRing(idx.x(), idx.y(), idx.z())];
          voxel.value = kUnknown;
          voxel.mark = 0;
        }
      }
    }
    m.low[a] = low[a];
  }
  // The prior's points in the voxels that came in, taken in disjoint
  // boxes: along each axis in turn, the slabs new along it, within what was
  // in the old window along the axes before it.
  if (!m.prior.empty() && low != old_low) {
    Eigen::Vector3i first = low, last = low + m.dims - Eigen::Vector3i::Ones();
    for (int a = 0; a < 3; ++a) {
      const int old_first = old_low[a], old_last = old_low[a] + m.dims[a] - 1;
      Eigen::Vector3i slab_first = first, slab_last = last;
      if (low[a] > old_low[a]) {
        slab_first[a] = std::max(first[a], old_last + 1);
      } else if (low[a] < old_low[a]) {
        slab_last[a] = std::min(last[a], old_first - 1);
      } else {
        continue;
      }
      m.SeedPrior(slab_first, slab_last);
      first[a] = std::max(first[a], old_first);
      last[a] = std::min(last[a], old_last);
      if (first[a] > last[a]) break;
    }
  }
  m.centre = centre;
  // The kept returns of voxels no longer occupied (freed, or left behind)
  // are dropped here to bound the memory. OccupiedPoints checks each voxel
  // anyway, so a sweep is needed only once the table has grown by half or
  // the window has moved a quarter of its size: a sweep walks the whole
  // table, and every frame moves the window.
  const bool moved_far = ((m.low - m.swept_low).cwiseAbs().array() * 4 >= m.dims.array()).any();
  if (!moved_far && m.raw.size() <= m.swept_size + m.swept_size / 2) return;
  m.swept_low = m.low;
  for (auto it = m.raw.begin(); it != m.raw.end();) {
    const Eigen::Vector3i v = it->second.empty() ? Eigen::Vector3i::Zero() : m.VoxelOf(it->second.front());
    if (it->second.empty() || !m.Occupied(v)) {
      it = m.raw.erase(it);
    } else {
      ++it;
    }
  }
  m.swept_size = std::max<size_t>(m.raw.size(), 1024);
}

core::Status RollingMap::SetPrior(const std::vector<Vec3>& points) {
  Impl& m = *impl_;
  if (!m.prior.empty()) return core::Status::InvalidArgument("rolling map: the prior map is set already");
  for (const Vec3& p : points) {
    if (!p.allFinite()) {
      ++m.dropped;
      continue;
    }
    m.prior[Impl::ChunkKey(m.VoxelOf(p))].push_back(p);
    ++m.prior_points;
  }
  m.SeedPrior(m.low, m.low + m.dims - Eigen::Vector3i::Ones());
  return core::Status::Ok();
}

size_t RollingMap::prior_points() const { return impl_->prior_points; }

void RollingMap::MarkFree(const Vec3& centre, double radius) {
  Impl& m = *impl_;
  if (!centre.allFinite() || !(radius > 0.0) || !std::isfinite(radius)) return;
  const double res = m.options.resolution;
  const Eigen::Vector3i first = m.VoxelOf(centre - Vec3::Constant(radius)).cwiseMax(m.low);
  const Eigen::Vector3i last = m.VoxelOf(centre + Vec3::Constant(radius)).cwiseMin(m.low + m.dims - Eigen::Vector3i::Ones());
  for (int i = first.x(); i <= last.x(); ++i) {
    for (int j = first.y(); j <= last.y(); ++j) {
      for (int k = first.z(); k <= last.z(); ++k) {
        const Eigen::Vector3i v(i, j, k);
        if (((v.cast<double>().array() + 0.5).matrix() * res - centre).norm() > radius) continue;
        m.cells[m.Cell(v)].value = static_cast<std::int8_t>(kClampLow);
        m.raw.erase(Impl::Key(v));
      }
    }
  }
}

std::vector<Vec3> RollingMap::ObstacleBoundary(const Vec3& lo, const Vec3& hi) const {
  const Impl& m = *impl_;
  std::vector<Vec3> centres;
  if (!lo.allFinite() || !hi.allFinite() || (hi.array() < lo.array()).any()) return centres;
  const FreeBox box = m.FreeOfBox(lo, hi);
  const Eigen::Vector3i first = box.first, size = box.size;
  const double res = m.options.resolution;
  const size_t stride_y = static_cast<size_t>(size.z()), stride_x = static_cast<size_t>(size.y()) * stride_y;
  // Each voxel of the box once: whether it is free, and whether it is
  // listed already (a voxel outside the box touches one box voxel by a face,
  // so it is met once).
  std::vector<std::uint8_t> state = box.free;
  constexpr std::uint8_t kIsFree = 1, kListed = 2;
  auto centre = [&](int i, int j, int k) {
    return Vec3((first.x() + i + 0.5) * res, (first.y() + j + 0.5) * res, (first.z() + k + 0.5) * res);
  };
  // A neighbour (di, dj, dk) of box voxel (i, j, k) at local index `at`.
  auto visit = [&](int i, int j, int k, int di, int dj, int dk, bool inside, size_t at) {
    if (!inside) {
      centres.push_back(centre(i + di, j + dj, k + dk));
      return;
    }
    std::uint8_t& s = state[at];
    if (s & (kIsFree | kListed)) return;
    s |= kListed;
    centres.push_back(centre(i + di, j + dj, k + dk));
  };
  for (int i = 0; i < size.x(); ++i) {
    for (int j = 0; j < size.y(); ++j) {
      const size_t row = static_cast<size_t>(i) * stride_x + j * stride_y;
      for (int k = 0; k < size.z(); ++k) {
        const size_t at = row + static_cast<size_t>(k);
        if (!(state[at] & kIsFree)) continue;
        // The faces in a fixed order (+x, -x, +y, -y, +z, -z): the list's
        // order does not depend on how the box is stored.
        visit(i, j, k, 1, 0, 0, i + 1 < size.x(), at + stride_x);
        visit(i, j, k, -1, 0, 0, i > 0, at - stride_x);
        visit(i, j, k, 0, 1, 0, j + 1 < size.y(), at + stride_y);
        visit(i, j, k, 0, -1, 0, j > 0, at - stride_y);
        visit(i, j, k, 0, 0, 1, k + 1 < size.z(), at + 1);
        visit(i, j, k, 0, 0, -1, k > 0, at - 1);
      }
    }
  }
  return centres;
}

FreeRegion RollingMap::ConnectedFree(const Vec3& lo, const Vec3& hi, const Vec3& from) const {
  const Impl& m = *impl_;
  FreeRegion region;
  region.resolution = m.options.resolution;
  if (!lo.allFinite() || !hi.allFinite() || !from.allFinite() || (hi.array() < lo.array()).any()) return region;
  const FreeBox box = m.FreeOfBox(lo, hi);
  region.first = box.first;
  region.size = box.size;
  region.in.assign(box.free.size(), 0);
  const Eigen::Vector3i seed = m.VoxelOf(from) - box.first;
  if ((seed.array() < 0).any() || (seed.array() >= box.size.array()).any()) return region;
  // Flooded on a copy padded by one voxel that is not free on every side,
  // so that a voxel's six neighbours are reached by offsets alone (at every
  // replan, over a box of half a million voxels).
  const Eigen::Vector3i padded = box.size + Eigen::Vector3i::Constant(2);
  const long pz = 1, py = padded.z(), px = static_cast<long>(padded.y()) * padded.z();
  // 0: not free or outside the box, 1: free, 2: reached.
  std::vector<std::uint8_t> state(static_cast<size_t>(px) * padded.x(), 0);
  const size_t stride_y = static_cast<size_t>(box.size.z()), stride_x = static_cast<size_t>(box.size.y()) * stride_y;
  for (int i = 0; i < box.size.x(); ++i) {
    for (int j = 0; j < box.size.y(); ++j) {
      const std::uint8_t* from_row = box.free.data() + static_cast<size_t>(i) * stride_x + j * stride_y;
      std::uint8_t* to_row = state.data() + (i + 1) * px + (j + 1) * py + 1;
      std::copy(from_row, from_row + box.size.z(), to_row);
    }
  }
  const long start = (seed.x() + 1) * px + (seed.y() + 1) * py + (seed.z() + 1);
  if (state[static_cast<size_t>(start)] != 1) return region;
  const long offsets[6] = {px, -px, py, -py, pz, -pz};
  std::vector<long> queue{start};
  state[static_cast<size_t>(start)] = 2;
  for (size_t q = 0; q < queue.size(); ++q) {
    const long n = queue[q];
    for (const long offset : offsets) {
      std::uint8_t& next = state[static_cast<size_t>(n + offset)];
      if (next != 1) continue;
      next = 2;
      queue.push_back(n + offset);
    }
  }
  for (int i = 0; i < box.size.x(); ++i) {
    for (int j = 0; j < box.size.y(); ++j) {
      const std::uint8_t* from_row = state.data() + (i + 1) * px + (j + 1) * py + 1;
      std::uint8_t* to_row = region.in.data() + static_cast<size_t>(i) * stride_x + j * stride_y;
      for (int k = 0; k < box.size.z(); ++k) to_row[k] = from_row[k] == 2;
    }
  }
  return region;
}

bool FreeRegion::Contains(const Vec3& p) const {
  if (in.empty() || !p.allFinite()) return false;
  const Eigen::Vector3i v = (p / resolution).array().floor().cast<int>().matrix() - first;
  if ((v.array() < 0).any() || (v.array() >= size.array()).any()) return false;
  return in[(static_cast<size_t>(v.x()) * size.y() + v.y()) * size.z() + v.z()] != 0;
}

double RollingMap::BoundaryBallRadius() const { return VoxelBallRadius(impl_->options.resolution); }

VoxelState RollingMap::State(const Vec3& p) const {
  const Impl& m = *impl_;
  if (!p.allFinite()) return VoxelState::kUnknown;
  const Eigen::Vector3i v = m.VoxelOf(p);
  if (!m.Inside(v)) return VoxelState::kUnknown;
  const std::int8_t value = m.cells[m.Cell(v)].value;
  if (value == kUnknown) return VoxelState::kUnknown;
  return value > m.threshold ? VoxelState::kOccupied : VoxelState::kFree;
}

std::vector<Vec3> RollingMap::OccupiedPoints() const {
  const Impl& m = *impl_;
  std::vector<Vec3> points;
  for (const auto& [key, kept] : m.raw) {
    if (kept.empty() || !m.Occupied(m.VoxelOf(kept.front()))) continue;
    points.insert(points.end(), kept.begin(), kept.end());
  }
  return points;
}

std::vector<Vec3> RollingMap::OccupiedVoxelCentres() const {
  const Impl& m = *impl_;
  std::vector<Vec3> centres;
  centres.reserve(m.raw.size());
  const double res = m.options.resolution;
  // Every occupied voxel was hit, so it keeps returns (the table holds it).
  for (const auto& [key, kept] : m.raw) {
    if (kept.empty()) continue;
    const Eigen::Vector3i v = m.VoxelOf(kept.front());
    if (m.Occupied(v)) centres.push_back((v.cast<double>().array() + 0.5).matrix() * res);
  }
  return centres;
}

std::vector<Vec3> RollingMap::UnknownVoxelCentres(const Vec3& lo, const Vec3& hi) const {
  const Impl& m = *impl_;
  std::vector<Vec3> centres;
  if (!lo.allFinite() || !hi.allFinite()) return centres;
  const Eigen::Vector3i first = m.VoxelOf(lo).cwiseMax(m.low), last = m.VoxelOf(hi).cwiseMin(m.low + m.dims - Eigen::Vector3i::Ones());
  const double res = m.options.resolution;
  for (int i = first.x(); i <= last.x(); ++i) {
    for (int j = first.y(); j <= last.y(); ++j) {
      for (int k = first.z(); k <= last.z(); ++k) {
        const Eigen::Vector3i v(i, j, k);
        if (m.cells[m.Cell(v)].value == kUnknown) centres.push_back((v.cast<double>().array() + 0.5).matrix() * res);
      }
    }
  }
  return centres;
}

const RollingMapOptions& RollingMap::options() const { return impl_->options; }
Vec3 RollingMap::window_centre() const { return impl_->centre; }
long RollingMap::frames() const { return impl_->frames; }
const std::vector<Vec3>& RollingMap::NewlyBlocked() const { return impl_->newly_blocked; }

long RollingMap::dropped_points() const { return impl_->dropped; }

size_t RollingMap::num_known_voxels() const {
  return static_cast<size_t>(std::count_if(impl_->cells.begin(), impl_->cells.end(),
                                           [](const Impl::Voxel& voxel) { return voxel.value != kUnknown; }));
}

size_t RollingMap::memory_bytes() const {
  const Impl& m = *impl_;
  size_t bytes = m.cells.size() * sizeof(Impl::Voxel) + m.touched.capacity() * sizeof(size_t);
  for (const auto& entry : m.raw) bytes += sizeof(entry) + entry.second.capacity() * sizeof(Vec3);
  for (const auto& entry : m.prior) bytes += sizeof(entry) + entry.second.capacity() * sizeof(Vec3);
  return bytes;
}

}  // namespace quadhand::perception
