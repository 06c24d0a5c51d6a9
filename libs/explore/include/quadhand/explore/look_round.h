// Looking round from where the vehicle holds (docs/perception.md, "Looking
// round"): a depth camera sees about 90 degrees of the horizon, so a vehicle
// put down facing a wall, or come to rest before one, may see no way on in
// front and every way on behind it. While the vehicle holds, each frame's
// heading is marked looked; when a plan from there finds no target, the
// vehicle turns in place (LocalPlanner::PlanTurnIn) to the heading not yet
// looked along that lies nearest the goal's bearing. Once the whole horizon
// has been looked along from there, it stops turning.
#pragma once

#include <optional>
#include <vector>

#include "quadhand/core/types.h"

namespace quadhand::explore {

class LookRound {
 public:
  // `field_of_view`: the sensor's horizontal field of view, rad (clamped
  // to (0, 2 pi]; a spinning LiDAR's is 2 pi, so one frame looks all round).
  explicit LookRound(double field_of_view);

  // Nothing looked along yet (the vehicle has moved on).
  void Clear();
  // A frame taken with the sensor's axis along `heading` (rad, world,
  // about z): every heading within half the field of view is looked along.
  void Looked(double heading);
  // Whether `heading` has been looked along.
  bool WasLooked(double heading) const;
  // The sensor's heading to turn to next: with the heading the sensor has
  // now (`now`), the heading nearest `preferred` (the goal's bearing) not
  // looked along; when it is `preferred` itself, that one; otherwise so that
  // the view's edge just takes it in (fewer, wider turns). None once every
  // heading has been looked along.
  std::optional<double> Next(double now, double preferred) const;

  // The heading of a sensor's axis (its frame's `axis` in the world):
  // none when the axis is within 10 degrees of vertical.
  static std::optional<double> HeadingOf(const Pose& sensor_in_world, const Vec3& axis);

 private:
  int BinOf(double heading) const;
  double field_of_view_;
  std::vector<bool> looked_;
};

}  // namespace quadhand::explore
