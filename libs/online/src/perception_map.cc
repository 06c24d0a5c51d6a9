#include "perception_map.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#ifdef __linux__
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>
#endif

namespace quadhand::online {
namespace {

// The key of the `resolution` cube holding p (21 bits per axis about the
// origin: +-100 km at 0.1 m); none beyond.
bool VoxelKey(const Vec3& p, double resolution, int64_t* key) {
  constexpr int64_t kHalf = int64_t{1} << 20;
  int64_t packed = 0;
  for (int axis = 0; axis < 3; ++axis) {
    const double cell = std::floor(p[axis] / resolution);
    if (!(cell >= -static_cast<double>(kHalf) && cell < static_cast<double>(kHalf))) return false;
    packed = (packed << 21) | (static_cast<int64_t>(cell) + kHalf);
  }
  *key = packed;
  return true;
}

// memory_bytes walks the kept returns: sampled, not every frame.
constexpr long kMemorySampleFrames = 30;

}  // namespace

PerceptionMap::PerceptionMap(const PerceptionSetup& setup)
    : setup_(setup), map_(std::move(*perception::RollingMap::Create(setup.map))), thread_([this] { Run(); }) {}

PerceptionMap::~PerceptionMap() {
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

void PerceptionMap::Start(const Vec3& position, double radius) {
  std::lock_guard<std::mutex> lock(map_mutex_);
  map_->MoveWindow(position);
  map_->MarkFree(position, radius);
  if (setup_.prior != nullptr && map_->prior_points() == 0) (void)map_->SetPrior(*setup_.prior);
}

void PerceptionMap::Push(perception::SensorFrame frame) {
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    if (waiting_.size() >= kMaxWaiting) {
      waiting_.pop_front();
      ++figures_.overrun;
    }
    waiting_.push_back(std::move(frame));
  }
  wake_.notify_all();
}

std::vector<Vec3> PerceptionMap::TakeBlocked() {
  std::lock_guard<std::mutex> lock(queue_mutex_);
  std::vector<Vec3> taken;
  taken.swap(blocked_);
  return taken;
}

explore::LocalMapSnapshot PerceptionMap::Snapshot(const explore::LocalPlanner& planner, const Vec3& about) const {
  std::lock_guard<std::mutex> lock(map_mutex_);
  return planner.Snapshot(*map_, about);
}

std::vector<Vec3> PerceptionMap::SeenPoints() {
  std::lock_guard<std::mutex> lock(map_mutex_);
  MergeSeenLocked();
  std::vector<Vec3> points;
  for (const auto& [key, returns] : seen_) points.insert(points.end(), returns.begin(), returns.end());
  return points;
}

void PerceptionMap::WaitUntilIdle() {
  std::unique_lock<std::mutex> lock(queue_mutex_);
  idle_.wait(lock, [this] { return waiting_.empty() && !inserting_; });
}

PerceptionMap::Figures PerceptionMap::figures() const {
  std::lock_guard<std::mutex> lock(queue_mutex_);
  return figures_;
}

void PerceptionMap::MergeSeenLocked() {
  // A depth camera's far returns are noisy (0.002 m times the depth
  // squared): a voxel in front of a surface seen from afar can read
  // occupied until the vehicle comes nearer and its rays pass through it.
  // So each voxel keeps what the map last said of it, not every return
  // it ever held.
  const double resolution = map_->options().resolution;
  std::unordered_map<int64_t, std::vector<Vec3>> occupied;
  for (const Vec3& p : map_->OccupiedPoints()) {
    int64_t key = 0;
    if (VoxelKey(p, resolution, &key)) occupied[key].push_back(p);
  }
  for (auto it = seen_.begin(); it != seen_.end();) {
    const Vec3 inside = it->second.front();  // a return in the voxel stands for it
    if (map_->State(inside) == perception::VoxelState::kFree) {
      it = seen_.erase(it);
      continue;
    }
    ++it;
  }
  for (auto& [key, returns] : occupied) seen_[key] = std::move(returns);
  size_t count = 0;
  for (const auto& entry : seen_) count += entry.second.size();
  std::lock_guard<std::mutex> lock(queue_mutex_);
  figures_.seen_points = count;
}

void PerceptionMap::Run() {
#ifdef __linux__
  // Below the setpoint stream, above the planner (10 lower): a map behind
  // the frames drops frames, a planner behind only plans later.
  const pid_t tid = static_cast<pid_t>(syscall(SYS_gettid));
  setpriority(PRIO_PROCESS, static_cast<id_t>(tid), getpriority(PRIO_PROCESS, static_cast<id_t>(tid)) + 5);
#endif
  for (;;) {
    perception::SensorFrame frame;
    {
      std::unique_lock<std::mutex> lock(queue_mutex_);
      wake_.wait(lock, [this] { return stop_ || !waiting_.empty(); });
      if (stop_) return;
      frame = std::move(waiting_.front());
      waiting_.pop_front();
      inserting_ = true;
    }
    const Pose pose = perception::SensorPose(frame);
    for (Vec3& p : frame.points) p = pose * p;
    for (Vec3& p : frame.misses) p = pose * p;
    std::vector<Vec3> blocked;
    double update_ms = 0.0;
    size_t bytes = 0;
    bool inserted = false;
    {
      std::lock_guard<std::mutex> lock(map_mutex_);
      const auto begin = std::chrono::steady_clock::now();
      map_->MoveWindow(pose.translation());
      // The gate refused a non-finite pose, the map's only error.
      inserted = map_->Insert(frame.points, pose.translation(), frame.misses).ok();
      update_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - begin).count();
      if (inserted) {
        blocked = map_->NewlyBlocked();
        if (map_->frames() % kMemorySampleFrames == 1) bytes = map_->memory_bytes();
        if (frame.t - last_merge_ >= setup_.seen_period) {
          MergeSeenLocked();
          last_merge_ = frame.t;
        }
      }
    }
    {
      std::lock_guard<std::mutex> lock(queue_mutex_);
      if (inserted) {
        figures_.update_ms.push_back(update_ms);
        figures_.peak_bytes = std::max(figures_.peak_bytes, bytes);
        if (frame.points.empty()) ++figures_.empty_frames;
        blocked_.insert(blocked_.end(), blocked.begin(), blocked.end());
      }
      inserting_ = false;
    }
    idle_.notify_all();
  }
}

}  // namespace quadhand::online
