// The rolling map of a flight on the sensor (controller.h, PerceptionSetup)
// in a thread of its own: a depth frame takes it 6-11 ms, and the setpoint
// stream must never wait for that. The controller's thread gates each frame
// and hands it over; this thread puts it into the map and collects the
// voxels it turned from free to occupied (TakeBlocked) for the controller
// to check its plans against. The planning worker takes its snapshot of
// the map here too (Snapshot), under the same lock.
#pragma once

#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <thread>
#include <unordered_map>
#include <vector>

#include "quadhand/explore/local_planner.h"
#include "quadhand/online/controller.h"
#include "quadhand/perception/rolling_map.h"
#include "quadhand/perception/sensor_frame.h"

namespace quadhand::online {

class PerceptionMap {
 public:
  // `setup` must be valid (PerceptionSetup::IsValid).
  explicit PerceptionMap(const PerceptionSetup& setup);
  ~PerceptionMap();
  PerceptionMap(const PerceptionMap&) = delete;
  PerceptionMap& operator=(const PerceptionMap&) = delete;

  // The window about `position`, and the space within `radius` free (the
  // vehicle stands there: no sensor sees it).
  void Start(const Vec3& position, double radius);
  // A frame the gate took (points and misses in the sensor's frame). At
  // most kMaxWaiting wait; the oldest waiting is dropped for a newer one
  // (counted: overrun), so the map is never more than that behind.
  void Push(perception::SensorFrame frame);
  // The voxels the frames put in since the last call turned from free to occupied.
  std::vector<Vec3> TakeBlocked();
  explore::LocalMapSnapshot Snapshot(const explore::LocalPlanner& planner, const Vec3& about) const;
  // The map's last word on every voxel it has seen (merged now): the raw
  // returns of each voxel last seen occupied, none of a voxel since seen
  // free; a voxel that left the window as it was last seen.
  std::vector<Vec3> SeenPoints();
  // Waits until every frame pushed is in the map (tests, the flight's end).
  void WaitUntilIdle();

  struct Figures {
    std::vector<double> update_ms;  // per frame, the window's move included
    size_t peak_bytes = 0;          // sampled every 30 frames
    long empty_frames = 0;
    long overrun = 0;               // frames dropped waiting (the map was behind)
    size_t seen_points = 0;
  };
  Figures figures() const;

  static constexpr size_t kMaxWaiting = 2;

 private:
  void Run();
  void MergeSeenLocked();

  PerceptionSetup setup_;
  // The controller's thread never waits for the map: the queue, what the
  // frames found and the figures have their own lock.
  mutable std::mutex queue_mutex_;
  std::condition_variable wake_, idle_;
  std::deque<perception::SensorFrame> waiting_;
  bool inserting_ = false;
  bool stop_ = false;
  std::vector<Vec3> blocked_;
  Figures figures_;
  mutable std::mutex map_mutex_;  // the map and the seen points
  std::unique_ptr<perception::RollingMap> map_;
  std::unordered_map<int64_t, std::vector<Vec3>> seen_;  // by voxel (VoxelKey)
  double last_merge_ = -1e300;  // the stamp of the frame merged at
  std::thread thread_;  // last: starts once everything above exists
};

}  // namespace quadhand::online
