// The online controller over a slow, lossy link, in-process and
// deterministic: the controller and the simulator's PX4-like autopilot talk
// through two seeded FaultChannels (link/fault_channel.h), one per direction.
// What was flown is judged on the simulator's own states (independently of
// the controller's figures) against the exact meshes.
#include <algorithm>
#include <cstring>
#include <deque>

#include <gtest/gtest.h>

#include "online/online_test_util.h"
#include "quadhand/link/fault_channel.h"
#include "quadhand/planner/time_scale.h"

namespace quadhand::online {
namespace {

using testing::MakeController;
using testing::WindowCup;

// Messages travel as indices into a store: the channel decides when (and
// whether) each one arrives.
class LinkedFlight {
 public:
  LinkedFlight(OnlineController* controller, const link::LinkFaults& up, const link::LinkFaults& down, uint64_t seed,
               const sim::FaultConfig& vehicle_faults = {})
      : controller_(controller), up_(up, 2 * seed + 1), down_(down, 2 * seed + 2) {
    const planner::Task& task = WindowCup().task;
    sim::StartPose start;
    start.position = task.start.position;
    start.yaw = task.start.yaw;
    start.joints = task.start.joints;
    sim::AutopilotOptions options;
    options.record_flown = true;
    auto autopilot = sim::Autopilot::Create(sim::Simulator(testing::VehicleModel(vehicle_faults), 5), start, options);
    EXPECT_TRUE(autopilot.ok()) << autopilot.status().message();
    autopilot_.emplace(std::move(*autopilot));
  }

  // Runs until `until` (s) or the controller finishes: the link in 2 ms
  // steps, the controller's ticks at 50 Hz.
  void Run(double until) {
    const LinkTargets targets;
    std::vector<link::Message> out;
    for (long step = 0;; ++step) {
      const double t = step * 0.002;
      if (t >= until || controller_->finished()) break;
      out.clear();
      ASSERT_TRUE(autopilot_->AdvanceTo(t, &out).ok());
      for (link::Message& m : out) down_.Push(t, Store(std::move(m)));
      for (const std::vector<uint8_t>& bytes : down_.PopDue(t)) {
        DeliverToController(Load(bytes), 1, t, targets, controller_);
      }
      if (step % 10 == 0) {
        const ControllerOutput tick = controller_->Tick(t);
        controller_->WaitUntilIdle();
        for (link::Message& m : MessagesFor(tick, t, targets)) up_.Push(t, Store(std::move(m)));
        ++ticks_;
      }
      for (const std::vector<uint8_t>& bytes : up_.PopDue(t)) {
        out.clear();
        autopilot_->Handle(Load(bytes), 255, 191, &out);
        for (link::Message& m : out) down_.Push(t, Store(std::move(m)));
      }
    }
  }

  const sim::Autopilot& autopilot() const { return *autopilot_; }
  const link::FaultChannel& up() const { return up_; }
  const link::FaultChannel& down() const { return down_; }

 private:
  std::vector<uint8_t> Store(link::Message m) {
    const uint64_t index = store_.size();
    store_.push_back(std::move(m));
    std::vector<uint8_t> bytes(sizeof index);
    std::memcpy(bytes.data(), &index, sizeof index);
    return bytes;
  }
  const link::Message& Load(const std::vector<uint8_t>& bytes) const {
    uint64_t index = 0;
    std::memcpy(&index, bytes.data(), sizeof index);
    return store_.at(index);
  }

  OnlineController* controller_;
  std::optional<sim::Autopilot> autopilot_;
  link::FaultChannel up_, down_;
  std::deque<link::Message> store_;
  long ticks_ = 0;
};

// The smallest exact clearance over the simulator's own record of the
// flight, from `from` s on: the independent verdict.
double FlownClearance(const std::vector<sim::PlanRow>& flown, double from) {
  const robot::RobotModel& robot = WindowCup().robot();
  robot::KinematicsState kinematics;
  double least = 1.0;
  for (const sim::PlanRow& row : flown) {
    if (row.t < from) continue;
    robot::ComputeKinematics(robot, MakePose(row.position, row.attitude.toRotationMatrix()), row.joints, &kinematics);
    least = std::min(least, env::WholeBodyClearance(kinematics, *WindowCup().exact, 0.3, {}));
  }
  return least;
}

double ToolError(const sim::VehicleState& s) {
  robot::KinematicsState kinematics;
  robot::ComputeKinematics(WindowCup().robot(), MakePose(s.position, s.attitude.toRotationMatrix()), s.joints,
                           &kinematics);
  return (kinematics.link_poses[WindowCup().robot().LinkIndex("tool")].translation() - WindowCup().task.tool->position)
      .norm();
}

link::LinkFaults SlowLossyLink() {
  link::LinkFaults f;
  f.delay = 0.15;
  f.jitter = 0.05;
  f.loss = 0.10;
  f.burst = 5.0;
  return f;
}

// The defect this guards against: over 150 +- 50 ms with 10 % loss in
// bursts, states judged at their arrival made every replan start 10-30 cm
// behind the vehicle, and the flight went into the scene while the online
// mode said "arrived".
TEST(LatencyTest, ASlowLossyLinkIsMeasuredAndTheFlightKeepsItsClearance) {
  auto controller = MakeController();
  LinkedFlight flight(controller.get(), SlowLossyLink(), SlowLossyLink(), 1);
  flight.Run(90.0);
  ASSERT_TRUE(controller->finished()) << PhaseName(controller->phase());
  EXPECT_EQ(controller->phase(), Phase::kArrived);

  // The link as the controller measured it: one-way 100-200 ms.
  ASSERT_TRUE(controller->clock_sync().synced());
  const LinkLatency latency = controller->clock_sync().latency();
  EXPECT_GT(latency.uplink, 0.10);
  EXPECT_LT(latency.uplink, 0.20);
  EXPECT_GT(latency.round_trip, 0.20);
  EXPECT_LT(latency.round_trip, 0.40);
  const OnlineStats& stats = controller->stats();
  EXPECT_GT(stats.stale_states_dropped, 0);  // jitter reorders: the older ones are not used
  EXPECT_GT(stats.max_state_age, 0.10);
  // An estimate that never jumped is never taken for one, however late,
  // out of order or far apart its states arrive.
  EXPECT_EQ(stats.estimate_jumps, 0);
  // Judged against the reference the vehicle was following, the tracking
  // error is not inflated by the latency (at 0.5 m/s and a 0.3 s round
  // trip it would read 15 cm).
  EXPECT_LT(stats.max_tracking_error, 0.08);
  // The plan was made for the link: slower than the task allows.
  ASSERT_FALSE(stats.plans.empty());
  EXPECT_LT(stats.plans.front().speed_limit, WindowCup().task.limits.v_max);
  EXPECT_GT(stats.plans.front().slowdown, 1.0);

  // Independently, on the simulator's own states.
  const double required = WindowCup().task.safety_distance - 0.002;
  EXPECT_GE(FlownClearance(flight.autopilot().flown(), 0.0), required);
  EXPECT_LT(ToolError(flight.autopilot().state()), 0.01);
  EXPECT_GT(flight.down().stats().lost, 0u);
  EXPECT_GT(flight.down().stats().reordered, 0u);
}

// An outage mid-flight: the vehicle brakes along the plan and holds, and
// once the link is back it flies a fresh plan to the goal.
TEST(LatencyTest, AnOutageBrakesAlongThePlanHoldsAndResumesWithAFreshPlan) {
  OnlineOptions options;
  options.vehicle_timeout = 5.0;  // longer than the outage: the vehicle is not given up
  auto controller = MakeController(options);
  link::LinkFaults faults;
  faults.outages.push_back({4.5, 0.8});  // down only: states stop, setpoints still arrive
  LinkedFlight flight(controller.get(), link::LinkFaults{}, faults, 2);
  flight.Run(60.0);
  ASSERT_TRUE(controller->finished()) << PhaseName(controller->phase());
  EXPECT_EQ(controller->phase(), Phase::kArrived);
  EXPECT_EQ(controller->stats().link_holds, 1);
  EXPECT_EQ(controller->stats().link_resumes, 1);
  const double required = WindowCup().task.safety_distance - 0.002;
  EXPECT_GE(FlownClearance(flight.autopilot().flown(), 0.0), required);
  EXPECT_LT(ToolError(flight.autopilot().state()), 0.01);
}

// An outage of 1.5 s both ways, longer than the autopilot's offboard-loss
// time-out and than vehicle_timeout: the autopilot's failsafe takes the
// vehicle out of OFFBOARD and holds it; once the link is good the online
// mode streams a hold where the vehicle is, requests OFFBOARD again and
// flies a fresh plan from there to the goal, within its clearance.
// Flies the default task through `up` and `down` (seed 4) and expects one
// hold, one re-engagement after the autopilot's failsafe, one fresh plan,
// and the goal reached within the clearance (the simulator's record).
void ExpectReengagedAndFlownToTheGoal(const link::LinkFaults& up, const link::LinkFaults& down) {
  auto controller = MakeController();
  LinkedFlight flight(controller.get(), up, down, 4);
  flight.Run(60.0);
  ASSERT_TRUE(controller->finished()) << PhaseName(controller->phase());
  EXPECT_EQ(controller->phase(), Phase::kArrived);
  EXPECT_EQ(controller->stats().link_holds, 1);
  EXPECT_EQ(controller->stats().reengagements, 1);
  EXPECT_EQ(controller->stats().link_resumes, 1);
  const double required = WindowCup().task.safety_distance - 0.002;
  EXPECT_GE(FlownClearance(flight.autopilot().flown(), 0.0), required);
  EXPECT_LT(ToolError(flight.autopilot().state()), 0.01);
}

TEST(LatencyTest, AfterTheAutopilotsFailsafeTheVehicleIsReengagedAndFlownToTheGoal) {
  link::LinkFaults faults;
  faults.outages.push_back({4.5, 1.5});
  ExpectReengagedAndFlownToTheGoal(faults, faults);
}

// The same outage on the uplink alone: the states keep coming, but no
// setpoint reaches the vehicle, and its offboard-loss failsafe takes it out
// of OFFBOARD. Our TIMESYNC requests went unanswered meanwhile, so the mode
// change is read as that failsafe (not as a pilot taking over): the flight
// is held, re-engaged once answers come again, and flown to the goal.
TEST(LatencyTest, AnUplinkOutageIsReadAsTheFailsafeAndTheFlightResumed) {
  link::LinkFaults up;
  up.outages.push_back({4.5, 1.5});
  ExpectReengagedAndFlownToTheGoal(up, link::LinkFaults{});
}

TEST(ClockSyncTest, TheLongestAnswerGapCountsTheSilenceSinceTheLastAnswer) {
  ClockSync clock;
  for (int k = 0; k < 10; ++k) {  // answered 10 ms after each request, the last at 0.91 s
    const double t = 0.1 * k;
    if (auto ts1 = clock.RequestDue(t)) clock.OnAnswer(t + 0.01, static_cast<int64_t>((t + 0.005) * 1e9), *ts1);
  }
  EXPECT_NEAR(clock.LongestAnswerGap(0.92, 0.0), 0.1, 1e-9);
  EXPECT_NEAR(clock.LongestAnswerGap(2.0, 0.0), 2.0 - 0.91, 1e-9);  // silent since 0.91 s
}

// Without TIMESYNC answers the flight does not start (the age of the
// states cannot be known), unless the caller chose to fly on arrival times.
TEST(LatencyTest, AVehicleThatNeverAnswersTimesyncIsNotFlown) {
  OnlineOptions options;
  options.connect_timeout = 3.0;
  auto controller = MakeController(options);
  const planner::Task& task = WindowCup().task;
  double t = 0.0;
  for (; t < 5.0 && !controller->finished(); t += 0.02) {
    controller->OnPosition(t, task.start.position, Vec3::Zero());
    controller->OnAttitude(t, Quat(Eigen::AngleAxisd(task.start.yaw, Vec3::UnitZ())), Vec3::Zero());
    controller->OnJoints(t, task.start.joints, VecX::Zero(3));
    const ControllerOutput out = controller->Tick(t);
    for (const CommandRequest& c : out.commands) controller->OnCommandAck(t, c.command, AckResult::kAccepted);
    controller->WaitUntilIdle();
  }
  EXPECT_EQ(controller->phase(), Phase::kHandshakeFailed);
  EXPECT_TRUE(controller->stats().plans.empty());  // nothing was planned, nothing flown
}

TEST(LatencyTest, StatesOlderThanTheNewestAreDropped) {
  auto controller = MakeController();
  controller->OnPosition(1.0, Vec3(1, 0, 0), Vec3::Zero());
  controller->OnPosition(0.9, Vec3(2, 0, 0), Vec3::Zero());  // overtaken on the way
  controller->OnPosition(1.0, Vec3(3, 0, 0), Vec3::Zero());  // a duplicate
  EXPECT_EQ(controller->stats().stale_states_dropped, 2);
  EXPECT_EQ(controller->stats().position_measurements, 1);
}

// The innovation gate: states that move as their velocities say, at any
// spacing, pass; a 2 cm step of the estimate is a jump, counted once with
// its size less what the motion explains.
TEST(LatencyTest, AnEstimateJumpIsCaughtByTheInnovationGate) {
  auto controller = MakeController();
  const Vec3 velocity(0.8, -0.3, 0.1), acceleration(1.5, 0.0, -1.0);
  double t = 1.0;
  auto state_at = [&](double s) { return Vec3(velocity * s + 0.5 * acceleration * s * s); };
  auto speed_at = [&](double s) { return Vec3(velocity + acceleration * s); };
  for (double dt : {0.02, 0.02, 0.3, 0.01, 0.5, 0.02}) {  // the gaps of a lossy link
    t += dt;
    controller->OnPosition(t, state_at(t), speed_at(t));
  }
  EXPECT_EQ(controller->stats().estimate_jumps, 0);
  // The clock's mapping refined by 12 ms between two states: the vehicle's
  // own stamps time the prediction, and nothing jumped.
  for (int k = 0; k < 2; ++k) {
    t += 0.02;
    controller->OnPosition(t + 0.012 * k, state_at(t), speed_at(t), t);
  }
  EXPECT_EQ(controller->stats().estimate_jumps, 0);
  t += 0.02;
  const Vec3 jump(0.0, 0.014, -0.014);
  controller->OnPosition(t + 0.012, state_at(t) + jump, speed_at(t), t);
  t += 0.02;
  controller->OnPosition(t + 0.012, state_at(t) + jump, speed_at(t), t);  // the estimate stays where it jumped
  EXPECT_EQ(controller->stats().estimate_jumps, 1);
  const double explained = 0.5 * OnlineOptions{}.innovation_acceleration * 0.02 * 0.02;
  EXPECT_NEAR(controller->stats().largest_estimate_jump, jump.norm() - explained, 1e-9);
  EXPECT_NEAR(controller->stats().estimate_jump_sum, controller->stats().largest_estimate_jump, 1e-12);
  EXPECT_NEAR(controller->stats().largest_estimate_jump_time, t - 0.02 + 0.012, 1e-12);
  // The setpoints are shifted by the whole jump, and the states are kept
  // less it: the second state after the jump is where the motion says.
  EXPECT_NEAR((controller->stats().estimate_shift - jump).norm(), 0.0, 1e-9);
  EXPECT_NEAR((controller->measured().position - state_at(t)).norm(), 0.0, 1e-9);
}

// Followed (shift_setpoints_on_jump off), a jump is only counted.
TEST(LatencyTest, AFollowedEstimateJumpIsCountedAndNotShifted) {
  OnlineOptions options;
  options.shift_setpoints_on_jump = false;
  auto controller = MakeController(options);
  controller->OnPosition(1.0, Vec3(1, 2, 3), Vec3::Zero());
  controller->OnPosition(1.02, Vec3(1, 2.03, 3), Vec3::Zero());
  EXPECT_EQ(controller->stats().estimate_jumps, 1);
  EXPECT_EQ(controller->stats().estimate_shift, Vec3::Zero());
  EXPECT_NEAR((controller->measured().position - Vec3(1, 2.03, 3)).norm(), 0.0, 1e-12);
}

// A 5 cm jump of the estimate 4 s into the flight, past the 3 cm safety
// distance: followed, the autopilot (which flies on its estimate) would
// fly the vehicle 5 cm off the plan. The setpoints shifted by the jump keep
// the simulator's true vehicle on the plan: its own record keeps the
// clearance and the tool reaches the cup. Followed, the same flight ends
// with the tool the jump away from the cup.
TEST(LatencyTest, AnEstimateJumpIsNotFlownTheSetpointsAreShiftedByIt) {
  sim::FaultConfig faults;
  faults.estimate.jump_time = 4.0;
  faults.estimate.jump = Vec3(0.0, 0.035, -0.035);
  const double required = WindowCup().task.safety_distance - 0.002;
  {
    auto controller = MakeController();
    LinkedFlight flight(controller.get(), link::LinkFaults{}, link::LinkFaults{}, 6, faults);
    flight.Run(60.0);
    ASSERT_TRUE(controller->finished()) << PhaseName(controller->phase());
    EXPECT_EQ(controller->phase(), Phase::kArrived);
    EXPECT_EQ(controller->stats().estimate_jumps, 1);
    EXPECT_LT((controller->stats().estimate_shift - faults.estimate.jump).norm(), 0.002);
    EXPECT_GE(FlownClearance(flight.autopilot().flown(), 0.0), required);
    EXPECT_LT(ToolError(flight.autopilot().state()), 0.01);
  }
  {
    OnlineOptions options;
    options.shift_setpoints_on_jump = false;
    auto controller = MakeController(options);
    LinkedFlight flight(controller.get(), link::LinkFaults{}, link::LinkFaults{}, 6, faults);
    flight.Run(60.0);
    EXPECT_EQ(controller->stats().estimate_jumps, 1);
    EXPECT_GT(ToolError(flight.autopilot().state()), 0.03);
  }
}

TEST(LatencyTest, AStateIsNeverTakenAsYoungerThanItsArrival) {
  auto controller = MakeController();
  // Not synced: the arrival time.
  EXPECT_DOUBLE_EQ(controller->MeasurementTime(2.0, 100.0), 2.0);
  // Vehicle clock 10 s ahead, 40 ms each way.
  controller->Tick(0.0);
  controller->OnTimesync(0.08, static_cast<int64_t>(10.04e9), 0);
  ASSERT_TRUE(controller->clock_sync().synced());
  EXPECT_NEAR(controller->MeasurementTime(1.0, 10.96), 0.96, 1e-9);  // stamped 40 ms before arrival
  EXPECT_DOUBLE_EQ(controller->MeasurementTime(1.0, 11.5), 1.0);     // a stamp in our future
}

// ------------------------------------------------------------- clock sync

TEST(ClockSyncTest, SymmetricDelaysGiveTheOffsetExactly) {
  ClockSync clock;
  const double offset = 123.456, one_way = 0.05;
  for (double t = 0.0; t < 2.0; t += 0.01) {
    if (auto ts1 = clock.RequestDue(t)) {
      const double vehicle = t + one_way + offset;
      EXPECT_TRUE(clock.OnAnswer(t + 2 * one_way, std::llround(vehicle * 1e9), *ts1));
    }
  }
  ASSERT_TRUE(clock.synced());
  EXPECT_NEAR(clock.ToLocal(offset + 1.0), 1.0, 1e-6);
  const LinkLatency l = clock.latency();
  EXPECT_NEAR(l.round_trip, 0.1, 1e-6);
  EXPECT_NEAR(l.uplink, 0.05, 1e-6);
  EXPECT_NEAR(l.uncertainty, 0.05, 1e-6);
}

TEST(ClockSyncTest, JitterDoesNotMoveTheEstimateBeyondHalfTheShortestRoundTrip) {
  ClockSync clock;
  std::mt19937 random(3);
  std::uniform_real_distribution<double> delay(0.02, 0.2);
  const double offset = -7.0;
  for (double t = 0.0; t < 3.0; t += 0.01) {
    if (auto ts1 = clock.RequestDue(t)) {
      const double up = delay(random), down = delay(random);
      clock.OnAnswer(t + up + down, std::llround((t + up + offset) * 1e9), *ts1);
    }
  }
  ASSERT_TRUE(clock.synced());
  const LinkLatency l = clock.latency();
  EXPECT_LE(std::abs(clock.ToLocal(offset + 2.0) - 2.0), l.uncertainty + 1e-9);
  EXPECT_GT(l.round_trip_max, l.round_trip);
}

TEST(ClockSyncTest, IgnoresRequestsAndAnswersToOthers) {
  ClockSync clock;
  EXPECT_FALSE(clock.OnAnswer(1.0, 5, 0));  // nothing asked yet
  const int64_t ts1 = *clock.RequestDue(1.0);
  EXPECT_FALSE(clock.RequestDue(1.05).has_value());  // not due yet
  EXPECT_FALSE(clock.OnAnswer(1.1, 0, ts1));          // tc1 0: a request, not an answer
  EXPECT_FALSE(clock.OnAnswer(1.1, 5, ts1 - 500000000));  // sent before our first request
  EXPECT_FALSE(clock.OnAnswer(1.1, 5, ts1 + 500000000));  // sent in our future
  EXPECT_FALSE(clock.synced());
  EXPECT_TRUE(clock.OnAnswer(1.1, 5, ts1));
  EXPECT_TRUE(clock.synced());
}

// ------------------------------------------------------------- slowing down

// Without an insertion the slowed plan is the same trajectory in uniformly
// scaled time: positions equal, velocities / factor, accelerations /
// factor^2, to rounding.
TEST(SlowDownTest, TheSlowedPlanIsTheSamePathInScaledTimeAndIsCertifiedAfresh) {
  planner::Task task = WindowCup().task;
  task.tool->has_insertion = false;
  task.tool->insertion_length = 0.0;
  const auto plan = planner::Plan(WindowCup().Scene(), task, testing::Setup().plan_options, testing::Solver());
  ASSERT_TRUE(plan.ok() && plan->success) << (plan.ok() ? plan->message : plan.status().message());
  ASSERT_FALSE(plan->insertion.enabled);
  const double factor = 2.5;
  const auto slowed = planner::SlowDown(*plan, factor, WindowCup().Scene(), task, testing::Setup().plan_options);
  ASSERT_TRUE(slowed.ok()) << slowed.status().message();
  EXPECT_TRUE(slowed->success) << slowed->message;
  const planner::WholeBodyTrajectory& a = *plan->trajectory;
  const planner::WholeBodyTrajectory& b = *slowed->trajectory;
  EXPECT_NEAR(b.duration(), factor * a.duration(), 1e-9);
  for (double t = 0.0; t <= a.duration(); t += a.duration() / 37.0) {
    const planner::WholeBodySample sa = a.Sample(t), sb = b.Sample(factor * t);
    EXPECT_LT((sa.position - sb.position).norm(), 1e-7) << t;
    EXPECT_LT((sa.velocity / factor - sb.velocity).norm(), 1e-7) << t;
    EXPECT_LT((sa.acceleration / (factor * factor) - sb.acceleration).norm(), 1e-6) << t;
    EXPECT_LT((sa.joints - sb.joints).norm(), 1e-7) << t;
    EXPECT_NEAR(sa.yaw, sb.yaw, 1e-7) << t;
  }
  EXPECT_NEAR(planner::PeakSpeed(b), planner::PeakSpeed(a) / factor, 0.01 * planner::PeakSpeed(a));
  // A factor outside [1, 1000] is an error.
  EXPECT_FALSE(planner::SlowDown(*plan, 0.5, WindowCup().Scene(), task, testing::Setup().plan_options).ok());
  EXPECT_FALSE(
      planner::SlowDown(*plan, std::nan(""), WindowCup().Scene(), task, testing::Setup().plan_options).ok());
}

// With an insertion, the straight descent keeps its own timing: the tool
// stays on its line only with the attitudes it was planned with (slowed
// uniformly 2.5x, the default plan's tool leaves the line by 13 mm). The
// transit is slowed through the same waypoints and the whole is certified.
TEST(SlowDownTest, AnInsertionKeepsItsTimingAndTheTransitSlowsDown) {
  const planner::Task& task = WindowCup().task;
  const auto plan = planner::Plan(WindowCup().Scene(), task, testing::Setup().plan_options, testing::Solver());
  ASSERT_TRUE(plan.ok() && plan->success) << (plan.ok() ? plan->message : plan.status().message());
  ASSERT_TRUE(plan->insertion.enabled);
  const double factor = 2.5;
  const auto slowed = planner::SlowDown(*plan, factor, WindowCup().Scene(), task, testing::Setup().plan_options);
  ASSERT_TRUE(slowed.ok()) << slowed.status().message();
  EXPECT_TRUE(slowed->success) << slowed->message;
  const traj::Minco& a = plan->trajectory->position();
  const traj::Minco& b = slowed->trajectory->position();
  ASSERT_EQ(a.num_pieces(), b.num_pieces());
  const int last = a.num_pieces() - 1;
  EXPECT_NEAR(b.durations()[last], a.durations()[last], 1e-12);
  for (int i = 0; i < last; ++i) {
    EXPECT_NEAR(b.durations()[i], factor * a.durations()[i], 1e-9);
    EXPECT_LT((a.Evaluate(i, a.durations()[i], 0) - b.Evaluate(i, b.durations()[i], 0)).norm(), 1e-9) << i;
  }
  EXPECT_LT(planner::PeakSpeed(*slowed->trajectory), planner::PeakSpeed(*plan->trajectory) / 2.0);
}

}  // namespace
}  // namespace quadhand::online
