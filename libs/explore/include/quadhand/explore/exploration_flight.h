// A flight into a scene the planner has never seen, simulated in lockstep
// (docs/perception.md, "Flying on the sensor"): the simulator flies the
// vehicle, a simulated sensor on it renders the hidden true scene, each
// frame goes into the rolling map, and the local planner (local_planner.h)
// replans from the map alone at a fixed period. Not real time: the
// simulated clock waits while the planner works, and each new plan starts
// plan_ahead seconds after the state it was asked from (on the plan being
// flown), which the vehicle flies meanwhile; the planner's wall time per
// replan is measured and reported beside it.
//
//   t = 0: at rest at the task's start; the space within start_free_radius
//          is free (the vehicle stands there)
//   every frame period: render, move the map's window to the sensor, insert
//          (voxels a frame turns from free to occupied within the planned
//          safety distance of the plan ahead: brake, and replan at once)
//   every replan period (until a plan to the goal is held):
//          plan from the flown plan's state at t + plan_ahead; a certified
//          plan replaces the flown one there; a failed one leaves it; at
//          rest, a failed one turns the vehicle in place to look round
//          (look_round), once per heading not yet looked along from there
//   arrived: the plan to the goal flown to its end, and the vehicle within
//          goal_tolerance of the goal
//
// Each frame passes a gate (perception/sensor_frame.h) before the map takes
// it. When no frame has been taken for sensor_timeout, the sensor is silent:
// the plan waiting to be flown is dropped, the plan being flown brakes along
// its own path (its clock slows to a stop: the plan's positions, yaws and
// joints, not its tilts) and holds there, and nothing is planned until
// frames are taken again.
#pragma once

#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/explore/grasp_under_perception.h"
#include "quadhand/explore/local_planner.h"
#include "quadhand/explore/sensor_faults.h"
#include "quadhand/perception/rolling_map.h"
#include "quadhand/perception/sensor_frame.h"
#include "quadhand/sim/sensor.h"
#include "quadhand/sim/simulator.h"

namespace quadhand::explore {

struct ExplorationOptions {
  perception::RollingMapOptions map;
  // A prior map: obstacles known before take-off (RollingMap::SetPrior),
  // such as a scan made on an earlier day. It adds obstacles where the
  // sensor has seen nothing and frees no space; the guide (guide_cell)
  // routes round it from the start. Not given to the grasp map.
  std::shared_ptr<const std::vector<Vec3>> prior;
  double replan_period = 0.5;  // s of flight between replans
  // s: a new plan starts this long after the state it plans from, the
  // vehicle flying the current plan meanwhile (what a real planner's
  // latency asks; the wall time per plan is reported beside it).
  double plan_ahead = 0.2;
  // The vehicle's own space at take-off is free (no sensor sees it), m.
  double start_free_radius = 0.8;
  // A pixel or beam that returns nothing frees its ray to the sensor's
  // range (sim::SensorRenderer::LastMisses: every miss_stride-th along each
  // axis); without it only rays that hit something free space, and open
  // sky stays unknown.
  bool free_misses = true;
  int miss_stride = 8;
  double goal_tolerance = 0.15;  // m
  // At rest with nothing certified, or offered only a hop that brings the
  // goal no nearer (LocalPlanResult::progress): turn in place first to a
  // heading not looked along since the last progress (look_round.h),
  // nearest the goal's bearing first.
  bool look_round = true;
  perception::FrameGateOptions frame_gate;
  // s without a frame taken before the vehicle brakes and holds.
  double sensor_timeout = 0.3;
  // Faults injected into the simulated sensor's stream, and their seed.
  SensorFaultOptions sensor_faults;
  uint64_t fault_seed = 1;
  // The flight ends unarrived after this long (s; 0: 3x the straight
  // line at v_max, plus 30 s), or after stuck_time with no new plan while
  // the last one has ended.
  double time_limit = 0.0;
  double stuck_time = 15.0;
  double record_period = 0.01;  // s between recorded states
  bool IsValid(std::string* why) const;
};

// kGraspNotCertified: the vehicle came to the grasp's staging state, but
// no plan of the grasp was certified on the grasp map in
// GraspFlight::attempts tries.
enum class ExplorationOutcome { kArrived, kTimeLimit, kStuck, kDiverged, kGraspNotCertified };
const char* ExplorationOutcomeName(ExplorationOutcome outcome);

struct ReplanRecord : LocalPlanSummary {
  double t = 0.0;  // simulated time it was asked at
  int leg = 0;     // the leg (goal) it planned towards, from 0
};

// The hidden world the simulated sensor renders: `renderer` from the start,
// and each of `changes` (in time order) from its time on, such as the same
// world with an obstacle that appears.
struct HiddenWorld {
  sim::SensorRenderer* renderer = nullptr;
  std::vector<std::pair<double, sim::SensorRenderer*>> changes;
  sim::SensorRenderer* At(double t) const;
};

// A plan found crossing a new obstacle: voxels a frame turned from free to
// occupied (RollingMap::NewlyBlocked) within the planned safety distance of
// the plan ahead. The plan being flown brakes along its path and a replan
// is asked at once; a waiting plan is dropped.
struct InvalidationRecord {
  double t = 0.0;             // s
  bool flown = false;         // the plan being flown (else only the waiting one)
  double conflict_in = 0.0;   // s of the plan's own time until the conflict (the flown plan)
  double stop_margin = 0.0;   // s of plan time between the brake's stop and the conflict (negative: past it)
  size_t new_obstacles = 0;   // voxels
  bool grasp = false;         // the grasp's plan, against the grasp map's new obstacles
};

// A time the sensor was silent, and the brake it caused.
struct SilenceRecord {
  double from = 0.0;  // s: when the timeout ran out (the last frame taken was sensor_timeout earlier)
  double to = 0.0;    // s: the next frame taken (the flight's end if none)
  bool ended = false; // a frame was taken again
  double speed = 0.0; // m/s: the plan's speed where it braked (0: it was at rest)
  double brake_s = 0.0; // s: the brake's duration (0: nothing to brake)
};

// A grasp flown under perception once the last leg has arrived at its
// staging state (grasp_under_perception.h): the grasp map is fed every
// frame from take-off; the work is planned on it from where the vehicle
// rests, again a replan period later (after more frames) while it is not
// certified, and a certified plan is flown to its end, the gripper closing
// at its grasp step (the simulator then carries the object's mass where
// the flown tool holds it). Not checked again against new obstacles while
// flown. A silence of the sensor brakes it and ends the flight unarrived.
struct GraspFlight {
  const GraspWork* work = nullptr;
  const GraspPlanner* planner = nullptr;
  GraspOptions options;
  int attempts = 6;
};
struct GraspAttempt {
  double t = 0.0;  // simulated time it was asked at
  bool certified = false;
  std::string message;
  size_t obstacles = 0;  // grasp-map boundary voxels planned against
  double ms = 0.0;       // wall time
};
struct ExplorationResult {
  ExplorationOutcome outcome = ExplorationOutcome::kTimeLimit;
  double flight_s = 0.0;  // simulated: to the arrival, or until it ended
  std::vector<sim::FlownSample> samples;
  std::vector<ReplanRecord> replans;
  std::vector<double> map_update_ms;  // per frame, the window's move included
  long frames = 0, empty_frames = 0;  // taken by the map, and those with no return
  perception::FrameCounts frame_counts;  // the gate's: taken and dropped, by reason
  long dropped_points = 0;               // non-finite returns of frames taken, and of the prior
  size_t prior_points = 0;               // the prior map's finite points (ExplorationOptions::prior)
  SensorFaultCounts injected;            // the faults injected (SensorFaultOptions)
  std::vector<SilenceRecord> silences;
  std::vector<InvalidationRecord> invalidations;
  size_t peak_map_bytes = 0;  // sampled every 30th frame taken, and at the end
  double goal_distance = 0.0;  // at the end, to the goal of the leg being flown, m
  int legs = 1;                // goals to reach in turn (LegsOfTask)
  int legs_arrived = 0;        // of them, reached (all of them: kArrived)
  // With a grasp (GraspFlight): each plan of it, the grasp map's update
  // time per frame, and when the gripper closed and the flown tool's
  // distance from the reach's tool point then (NaN: never closed).
  std::vector<GraspAttempt> grasp_attempts;
  std::vector<double> grasp_map_update_ms;
  double grasp_closed_t = std::numeric_limits<double>::quiet_NaN();
  double grasp_tool_error = std::numeric_limits<double>::quiet_NaN();
};

// One flight. `simulator` is reset to the task's start; `world` renders
// the hidden scene for `sensor`'s link and mount; `progress`, when set, is
// called after each replan. Errors only for inconsistent input.
core::Result<ExplorationResult> FlyExploration(sim::Simulator* simulator, const sim::SensorConfig& sensor,
                                               const HiddenWorld& world, const LocalPlanner& planner,
                                               const planner::Task& task, const ExplorationOptions& options,
                                               const std::function<void(const ReplanRecord&)>& progress = nullptr);

// The same through goals in turn (a mission of reaches: LegsOfTask), one
// local planner per leg, each planning to its own goal. The map and the
// vehicle carry on from leg to leg: once a leg's plan to its goal has been
// flown to its end within goal_tolerance, the next leg plans at once from
// there. Arrived when the last leg has; the time limit (0: from the
// straight lines between the goals) is for the whole flight.
core::Result<ExplorationResult> FlyExploration(sim::Simulator* simulator, const sim::SensorConfig& sensor,
                                               const HiddenWorld& world, const std::vector<const LocalPlanner*>& legs,
                                               const planner::Task& task, const ExplorationOptions& options,
                                               const std::function<void(const ReplanRecord&)>& progress = nullptr);
// The same, then the grasp (the legs from LegsOfTask(task, grasp.work)).
core::Result<ExplorationResult> FlyExploration(sim::Simulator* simulator, const sim::SensorConfig& sensor,
                                               const HiddenWorld& world, const std::vector<const LocalPlanner*>& legs,
                                               const planner::Task& task, const ExplorationOptions& options,
                                               const GraspFlight& grasp,
                                               const std::function<void(const ReplanRecord&)>& progress = nullptr);

}  // namespace quadhand::explore
