// The online controller flying the simulated vehicle in-process: the default
// task to the cup (through the MAVLink messages and the simulator's PX4-like
// autopilot), a push that triggers a replan spliced in smoothly, a replan
// that fails and leaves the vehicle holding, a silent vehicle, and the
// offboard handshake's retries and refusals.
#include <algorithm>
#include <atomic>
#include <limits>

#include <gtest/gtest.h>

#include "online/online_test_util.h"
#include "quadhand/traj/flatness.h"

namespace quadhand::online {
namespace {

using testing::DirectFlight;
using testing::MakeController;
using testing::WindowCup;

const Vec3& CupPosition() { return WindowCup().task.tool->position; }

FlightMetrics Metrics(const FlightLog& log, const OnlineController& controller) {
  return EvaluateFlight(log.samples(), WindowCup().robot(), *WindowCup().exact, WindowCup().task,
                        controller.current_plan()->terminal.position);
}

// The simulated autopilot hovering at the default task's start.
core::Result<sim::Autopilot> AutopilotAtTheTasksStart() {
  const planner::Task& task = WindowCup().task;
  sim::StartPose start;
  start.position = task.start.position;
  start.yaw = task.start.yaw;
  start.joints = task.start.joints;
  return sim::Autopilot::Create(sim::Simulator(testing::VehicleModel(), 3), start, sim::AutopilotOptions{});
}

// The whole message path: controller -> MAVLink messages -> autopilot ->
// simulator -> telemetry messages -> controller.
// A mission's plan clock: plan time runs with controller time except where
// it stood still at a junction; the time the plan left a point is after
// the pause there.
TEST(PlanClockTest, StandsStillAtItsPausesAndNowhereElse) {
  PlanClock clock{10.0, {{2.0, 1.5}, {5.0, 0.5}}};
  EXPECT_DOUBLE_EQ(clock.PlanTime(10.0), 0.0);
  EXPECT_DOUBLE_EQ(clock.PlanTime(11.0), 1.0);
  EXPECT_DOUBLE_EQ(clock.PlanTime(12.0), 2.0);
  EXPECT_DOUBLE_EQ(clock.PlanTime(13.0), 2.0);   // in the first pause
  EXPECT_DOUBLE_EQ(clock.PlanTime(13.5), 2.0);
  EXPECT_DOUBLE_EQ(clock.PlanTime(14.5), 3.0);
  EXPECT_DOUBLE_EQ(clock.PlanTime(16.5), 5.0);
  EXPECT_DOUBLE_EQ(clock.PlanTime(16.75), 5.0);  // in the second
  EXPECT_DOUBLE_EQ(clock.PlanTime(18.0), 6.0);
  EXPECT_DOUBLE_EQ(clock.TimeLeaving(1.0), 11.0);
  EXPECT_DOUBLE_EQ(clock.TimeLeaving(2.0), 13.5);
  EXPECT_DOUBLE_EQ(clock.TimeLeaving(5.0), 17.0);
  EXPECT_DOUBLE_EQ(clock.TimeLeaving(6.0), 18.0);
  for (double t = 10.0; t < 20.0; t += 0.25) EXPECT_GE(clock.TimeLeaving(clock.PlanTime(t)), t - 1e-12) << t;
  const PlanClock unpaused{3.0, {}};
  EXPECT_DOUBLE_EQ(unpaused.PlanTime(4.0), 1.0);
}

TEST(OnlineControllerTest, FliesTheDefaultTaskToTheCupThroughTheAutopilot) {
  auto autopilot = AutopilotAtTheTasksStart();
  ASSERT_TRUE(autopilot.ok()) << autopilot.status().message();
  auto controller = MakeController();
  const LinkTargets targets;
  FlightLog log;
  std::vector<link::Message> from_vehicle, replies;
  double first_setpoint = -1.0, first_mode_request = -1.0;
  bool saw_offboard_ack = false, saw_arm_ack = false;
  double t = 0.0;
  for (; t < 40.0 && !controller->finished(); t += 0.02) {
    from_vehicle.clear();
    ASSERT_TRUE(autopilot->AdvanceTo(t, &from_vehicle).ok());
    for (const link::Message& m : from_vehicle) {
      DeliverToController(m, 1, t, targets, controller.get());
      if (const auto* ack = std::get_if<link::CommandAck>(&m)) {
        saw_offboard_ack |= ack->command == link::mav::kCmdDoSetMode && ack->result == link::mav::kResultAccepted;
        saw_arm_ack |= ack->command == link::mav::kCmdComponentArmDisarm && ack->result == link::mav::kResultAccepted;
      }
    }
    const ControllerOutput out = controller->Tick(t);
    controller->WaitUntilIdle();
    if (out.setpoint && first_setpoint < 0) first_setpoint = t;
    if (!out.commands.empty() && first_mode_request < 0) first_mode_request = t;
    replies.clear();
    for (const link::Message& m : MessagesFor(out, t, targets)) autopilot->Handle(m, 255, 190, &replies);
    for (const link::Message& m : replies) {
      DeliverToController(m, 1, t, targets, controller.get());
      if (const auto* ack = std::get_if<link::CommandAck>(&m)) {
        saw_offboard_ack |= ack->command == link::mav::kCmdDoSetMode && ack->result == link::mav::kResultAccepted;
        saw_arm_ack |= ack->command == link::mav::kCmdComponentArmDisarm && ack->result == link::mav::kResultAccepted;
      }
    }
    log.Record(controller->measured(), out.setpoint, out.phase);
  }
  ASSERT_TRUE(controller->finished()) << PhaseName(controller->phase()) << " at t = " << t;
  EXPECT_EQ(controller->phase(), Phase::kArrived);
  EXPECT_TRUE(controller->arrival_settled());
  EXPECT_TRUE(saw_offboard_ack);
  EXPECT_TRUE(saw_arm_ack);
  EXPECT_EQ(autopilot->mode(), sim::FlightMode::kOffboard);
  EXPECT_TRUE(autopilot->armed());
  // PX4's rule: setpoints streamed for at least a second before OFFBOARD is asked for.
  ASSERT_GE(first_setpoint, 0.0);
  EXPECT_GE(first_mode_request - first_setpoint, 1.0);
  EXPECT_EQ(autopilot->setpoints_rejected(), 0u);

  const FlightMetrics metrics = Metrics(log, *controller);
  EXPECT_LT(metrics.final_tool_error, 0.02) << "tool " << metrics.final_tool_error << " m from the cup";
  EXPECT_LT(metrics.tracking_max, 0.10);
  EXPECT_GT(metrics.min_clearance, 0.0) << "closest link " << metrics.closest_link;
  // The tool at the end, computed independently from the simulator's state.
  const sim::VehicleState& s = autopilot->state();
  robot::KinematicsState kinematics;
  robot::ComputeKinematics(WindowCup().robot(), MakePose(s.position, s.attitude.toRotationMatrix()), s.joints,
                           &kinematics);
  EXPECT_LT((kinematics.link_poses[WindowCup().robot().LinkIndex("tool")].translation() - CupPosition()).norm(), 0.02);
}

// The autopilot flies each setpoint until the next one, a streaming period
// later: the setpoints are sampled half a period ahead (measured from the
// ticks), or as far as OnlineOptions::setpoint_lead says.
TEST(OnlineControllerTest, SamplesTheSetpointsHalfAStreamingPeriodAhead) {
  for (const double lead : {-1.0, 0.0, 0.03}) {
    auto autopilot = AutopilotAtTheTasksStart();
    ASSERT_TRUE(autopilot.ok()) << autopilot.status().message();
    OnlineOptions options;
    options.setpoint_lead = lead;
    auto controller = MakeController(options);
    const LinkTargets targets;
    std::vector<link::Message> from_vehicle, replies;
    int compared = 0;
    double largest = 0.0, fastest = 0.0;
    for (double t = 0.0; t < 40.0 && !controller->finished(); t += 0.02) {
      from_vehicle.clear();
      ASSERT_TRUE(autopilot->AdvanceTo(t, &from_vehicle).ok());
      for (const link::Message& m : from_vehicle) DeliverToController(m, 1, t, targets, controller.get());
      const ControllerOutput out = controller->Tick(t);
      controller->WaitUntilIdle();
      if (out.setpoint && out.phase == Phase::kFlying) {
        const double expected = lead < 0.0 ? 0.01 : lead;
        const std::optional<Setpoint> ahead = controller->Reference(t + expected);
        ASSERT_TRUE(ahead.has_value());
        largest = std::max(largest, (out.setpoint->position - ahead->position).norm());
        fastest = std::max(fastest, ahead->velocity.norm());
        EXPECT_NEAR(controller->SetpointLead(), expected, 1e-9);
        ++compared;
      }
      replies.clear();
      for (const link::Message& m : MessagesFor(out, t, targets)) autopilot->Handle(m, 255, 190, &replies);
      for (const link::Message& m : replies) DeliverToController(m, 1, t, targets, controller.get());
    }
    EXPECT_GT(compared, 100) << "lead " << lead;
    EXPECT_GT(fastest, 0.5) << "lead " << lead;  // a lead shows only where the plan moves
    EXPECT_LT(largest, 1e-9) << "lead " << lead;
  }
}

TEST(OnlineControllerTest, APushTriggersAReplanThatIsSplicedWithoutAJump) {
  OnlineOptions options;
  auto controller = MakeController(options);
  DirectFlight flight(controller.get());
  double push_time = -1.0;
  flight.Run(40.0, [&](double t, sim::Simulator* sim) {
    // A gust: 1.2 m/s sideways, 1.5 s into the flight (before the windows).
    if (push_time < 0.0 && controller->phase() == Phase::kFlying && t - controller->current_plan_start() > 1.0) {
      push_time = t;
      sim::VehicleState s = sim->state();
      s.velocity += Vec3(0.0, 0.0, 0.8);
      sim->Reset(s, sim->time());
    }
  });
  ASSERT_GE(push_time, 0.0);
  const OnlineStats& stats = controller->stats();
  ASSERT_GE(stats.replans_triggered, 1);
  std::string plans;
  for (const PlanRecord& r : stats.plans) plans += std::string(planner::PlanStatusName(r.status)) + ": " + r.message + "\n";
  ASSERT_GE(stats.splices, 1) << plans;
  // The push is met by the tracking-error replan, not by a periodic one
  // from the pushed state: the vehicle's velocity is 0.8 m/s off its
  // reference then, not on track (OnlineOptions::periodic_max_velocity_error).
  for (const PlanRecord& record : stats.plans) {
    if (record.replan && record.requested_at >= push_time) {
      EXPECT_FALSE(record.periodic) << "the first replan after the push, at t = " << record.requested_at << " s";
      break;
    }
  }
  EXPECT_EQ(controller->phase(), Phase::kArrived);
  EXPECT_TRUE(controller->finished());
  // Every replan passed the post-check (or the controller would be holding).
  for (const PlanRecord& record : stats.plans) EXPECT_TRUE(record.success) << planner::PlanStatusName(record.status) << ": " << record.message;
  // No jump: between two 20 ms setpoints the position moves by no more than
  // the plans' speed allows plus the blend's share of the gap between them.
  const double v_max = WindowCup().task.limits.v_max;
  const double bound = BlendStepBound(v_max, options.replan_threshold + 0.3, options.blend_window, 0.02);
  EXPECT_GT(stats.max_splice_step, 0.0);
  EXPECT_LE(stats.max_splice_step, bound);
  EXPECT_LE(stats.max_setpoint_step, bound);
  EXPECT_LE(stats.max_splice_speed, bound / 0.02);
  // Still reaches the cup.
  const FlightMetrics metrics = Metrics(flight.log(), *controller);
  EXPECT_LT(metrics.final_tool_error, 0.02);
  EXPECT_GT(metrics.min_clearance, 0.0);
}

// At the goal the controller holds until the vehicle has settled, not for a
// fixed time: a gust at the start of the arrival hold keeps the vehicle
// moving past arrival_hold, and the flight ends only once the tool is back
// within arrival_tolerance of the cup and the base is slow; with arrival_timeout == arrival_hold the
// same gust ends a fixed hold with the vehicle still off.
// Flies the default task with a gust (0.3 m/s sideways) as the plan ends;
// returns when it came (-1: never).
double FlyWithAGustAtTheGoal(OnlineController* controller, DirectFlight* flight) {
  double arrived_at = -1.0;
  flight->Run(60.0, [&](double t, sim::Simulator* sim) {
    if (arrived_at < 0.0 && controller->phase() == Phase::kArrived) {
      arrived_at = t;
      sim::VehicleState s = sim->state();
      s.velocity += Vec3(0.3, 0.0, 0.0);
      sim->Reset(s, sim->time());
    }
  });
  return arrived_at;
}

TEST(OnlineControllerTest, HoldsAtTheGoalUntilTheVehicleHasSettled) {
  {
    OnlineOptions bad;
    bad.arrival_timeout = bad.arrival_hold - 0.1;
    std::string why;
    EXPECT_FALSE(bad.IsValid(&why));
    EXPECT_NE(why.find("arrival_timeout"), std::string::npos) << why;
    EXPECT_FALSE(OnlineController::Create(testing::Setup(), bad).ok());
  }
  for (const bool fixed_hold : {false, true}) {
    SCOPED_TRACE(fixed_hold ? "fixed hold" : "hold until settled");
    OnlineOptions options;
    options.replanning = false;
    options.arrival_hold = 0.2;
    // This gust pushes the gripper into the cup: by default, an abort (the
    // test below); here the settling is what is tested.
    options.abort_near_goal = false;
    if (fixed_hold) options.arrival_timeout = options.arrival_hold;
    auto controller = MakeController(options);
    DirectFlight flight(controller.get());
    const double arrived_at = FlyWithAGustAtTheGoal(controller.get(), &flight);
    ASSERT_GE(arrived_at, 0.0);
    ASSERT_TRUE(controller->finished());
    EXPECT_EQ(controller->phase(), Phase::kArrived);
    const MeasuredState last = controller->measured();
    robot::KinematicsState kinematics;
    robot::ComputeKinematics(WindowCup().robot(), MakePose(last.position, last.attitude.toRotationMatrix()),
                             last.joints, &kinematics);
    const Vec3 tool = kinematics.link_poses[WindowCup().robot().LinkIndex(WindowCup().task.tool_link)].translation();
    const double offset = (tool - CupPosition()).norm();
    // Tick() runs before the period's step: the finishing tick saw the state
    // one 20 ms period before the flight's end.
    const double held = flight.time() - 0.02 - arrived_at;
    if (fixed_hold) {
      EXPECT_FALSE(controller->arrival_settled());
      EXPECT_NEAR(held, options.arrival_hold, 0.021);
      EXPECT_GT(offset, options.arrival_tolerance);
    } else {
      EXPECT_TRUE(controller->arrival_settled());
      EXPECT_GT(held, options.arrival_hold + 0.1);
      EXPECT_LT(held, options.arrival_timeout);
      EXPECT_LE(offset, options.arrival_tolerance);
      EXPECT_LE(last.velocity.norm(), options.arrival_settle_speed);
    }
  }
}

// The same gust at the goal by default: the gripper is pushed closer to
// the cup than the safety distance less the tolerance, so the vehicle
// retreats along the plan backwards to the insertion's start, holds there
// and finishes aborted, never having touched the cup.
TEST(OnlineControllerTest, AGustAtTheGoalAbortsAndTheVehicleRetreatsAlongThePlan) {
  OnlineOptions options;
  options.replanning = false;
  auto controller = MakeController(options);
  DirectFlight flight(controller.get());
  const double arrived_at = FlyWithAGustAtTheGoal(controller.get(), &flight);
  ASSERT_GE(arrived_at, 0.0);
  ASSERT_TRUE(controller->finished());
  EXPECT_TRUE(controller->aborted());
  EXPECT_EQ(controller->phase(), Phase::kHoldingAfterFailure);
  // It ends above the cup, at the insertion's start (0.10 m up the line).
  const MeasuredState last = controller->measured();
  robot::KinematicsState kinematics;
  robot::ComputeKinematics(WindowCup().robot(), MakePose(last.position, last.attitude.toRotationMatrix()), last.joints,
                           &kinematics);
  const Vec3 tool = kinematics.link_poses[WindowCup().robot().LinkIndex(WindowCup().task.tool_link)].translation();
  EXPECT_LT((tool - (CupPosition() + Vec3(0.0, 0.0, 0.10))).norm(), 0.03) << tool.transpose();
  EXPECT_GT(Metrics(flight.log(), *controller).min_clearance, 0.0);
}

// A servo that stalls mid-flight (the simulator's servo fault): the joint
// stops while the plan moves it, and the flight is aborted where it is; the
// same flight with a slow servo (0.2 s of extra lag) is not a stall and
// arrives. (Before it is found, the base may already have strayed: the
// fault campaign's servo_stall rows measure how far.)
TEST(OnlineControllerTest, AStalledJointAbortsTheFlightWhereItIsAndASlowOneDoesNot) {
  OnlineOptions options;
  options.replanning = false;
  {
    auto controller = MakeController(options);
    sim::FaultConfig faults;
    faults.servo.stall_joint = 1;
    faults.servo.stall_time = 3.5;
    DirectFlight flight(controller.get(), faults);
    flight.Run(40.0);
    ASSERT_TRUE(controller->finished());
    EXPECT_TRUE(controller->aborted());
    EXPECT_TRUE(controller->joint_stalled()) << flight.Events();
    EXPECT_EQ(controller->phase(), Phase::kHoldingAfterFailure);
    EXPECT_NE(flight.Events().find("stopped along the plan: holding there"), std::string::npos) << flight.Events();
    // Within two seconds of the stall (the plan moves this joint slowly
    // there: it is found by how far it falls behind), at rest since.
    const std::string events = flight.Events();
    const size_t at = events.find("joint joint2 does not follow the plan");
    ASSERT_NE(at, std::string::npos) << events;
    const double found = std::stod(events.substr(events.rfind('[', at) + 1));
    EXPECT_LT(found, 3.5 + 2.0) << events;
    EXPECT_LT(flight.simulator().state().velocity.norm(), 0.1);
  }
  {
    auto controller = MakeController(options);
    sim::FaultConfig faults;
    faults.servo.extra_lag = 0.2;
    DirectFlight flight(controller.get(), faults);
    flight.Run(40.0);
    ASSERT_TRUE(controller->finished());
    EXPECT_FALSE(controller->aborted());
    EXPECT_EQ(controller->phase(), Phase::kArrived);
  }
}

// The plan a fault-free flight with `options` flies, and its start (the
// flights are deterministic: a later flight with a fault flies the same
// plan up to the fault); null when it was not flying 4 s in.
std::pair<std::shared_ptr<const planner::PlanResult>, double> PlanFlown(const OnlineOptions& options) {
  auto controller = MakeController(options);
  DirectFlight flight(controller.get());
  flight.Run(4.0);
  if (controller->phase() != Phase::kFlying) return {nullptr, 0.0};
  return {controller->current_plan(), controller->current_plan_start()};
}

// A joint stuck where the plan moves it too slowly for the rate check, and
// where being left behind takes long to show: the plan ahead with the joint
// where it stands comes too close to the scene, and that is found at once.
TEST(OnlineControllerTest, AJointStuckWhereThePlanMovesItSlowlyIsFoundByThePathAheadOfIt) {
  OnlineOptions options;
  options.replanning = false;
  const auto flown_plan = PlanFlown(options);
  const std::shared_ptr<const planner::PlanResult> plan = flown_plan.first;
  const double plan_start = flown_plan.second;
  ASSERT_TRUE(plan);
  const planner::Task& task = WindowCup().task;
  const double accepted = planner::AcceptedClearance(task, options.clearance_tolerance);
  const double reach = planner::ClearanceSearchReach(task);
  robot::KinematicsState kinematics;
  auto margin = [&](double tau, int joint, double angle) {
    const planner::WholeBodySample s = plan->trajectory->Sample(tau);
    MeasuredState m;
    m.position = s.position;
    m.attitude = Quat(s.BasePose().rotation());
    m.joints = s.joints;
    m.joints[joint] = angle;
    return MeasuredClearance(WindowCup().robot(), *WindowCup().exact, m, reach, &kinematics) - accepted;
  };
  // The first time and joint whose stall costs the clearance 0.3-1.1 s later
  // while the plan moves it under the rate check's 0.3 rad/s.
  double stall_at = -1.0;
  int joint = -1;
  for (double tau = 0.5; tau < plan->trajectory->duration() - 1.5 && joint < 0; tau += 0.05) {
    const planner::WholeBodySample s = plan->trajectory->Sample(tau);
    for (int k = 0; k < s.joints.size() && joint < 0; ++k) {
      const double rate = std::abs(s.joint_rates[k]);
      if (rate < 0.05 || rate > 0.25) continue;
      double least = std::numeric_limits<double>::infinity();
      for (double ahead = tau + 0.3; ahead <= tau + 1.1; ahead += 0.02) least = std::min(least, margin(ahead, k, s.joints[k]));
      if (least < -0.003) {
        stall_at = tau;
        joint = k;
      }
    }
  }
  ASSERT_GE(joint, 0) << "no slow joint whose stall costs the clearance on this plan";
  auto controller = MakeController(options);
  sim::FaultConfig faults;
  faults.servo.stall_joint = joint;
  faults.servo.stall_time = plan_start + stall_at;
  DirectFlight flight(controller.get(), faults);
  double flown = std::numeric_limits<double>::infinity();
  flight.Run(40.0, [&](double, sim::Simulator* sim) {
    MeasuredState m;
    m.position = sim->state().position;
    m.attitude = sim->state().attitude;
    m.joints = sim->state().joints;
    flown = std::min(flown, MeasuredClearance(WindowCup().robot(), *WindowCup().exact, m, reach, &kinematics));
  });
  ASSERT_TRUE(controller->joint_stalled()) << flight.Events();
  const std::string events = flight.Events();
  const size_t at = events.find("does not follow the plan");
  ASSERT_NE(at, std::string::npos) << events;
  EXPECT_NE(events.find("with it there, the plan", at), std::string::npos) << events;
  const double found = std::stod(events.substr(events.rfind('[', at) + 1));
  EXPECT_LT(found - faults.servo.stall_time, 0.6) << events;
  // Without the look-ahead: found 0.70 s after the stall, 1.95 cm flown.
  EXPECT_GT(flown, accepted) << events;
  std::printf("stall of joint %d at %.2f s: found %.2f s later; flown clearance %.4f m\n", joint + 1,
              faults.servo.stall_time, found - faults.servo.stall_time, flown);
}

// A quarter second of uplink lost while the plan moves a joint fast: the
// joints stand at their last setpoints, as a stalled joint would. The
// vehicle reports each servo's goal (JOINT_GOAL): standing at its goal, a
// joint has not stalled, and the flight goes on. A vehicle that does not
// report them leaves the stall check to the plan alone, and it aborts.
TEST(OnlineControllerTest, AJointStandingAtItsServosGoalDuringAnUplinkLossIsNotAStall) {
  OnlineOptions options;
  options.replanning = false;
  const auto flown_plan = PlanFlown(options);
  const std::shared_ptr<const planner::PlanResult> plan = flown_plan.first;
  const double plan_start = flown_plan.second;
  ASSERT_TRUE(plan);
  // Lost from 0.3 s into a stretch of 0.7 s where the plan moves a joint
  // at 0.4 rad/s or more, one way (the rate check's window is 0.3 s).
  double lost_at = -1.0;
  for (double tau = 0.5; tau < plan->trajectory->duration() - 1.0 && lost_at < 0.0; tau += 0.02) {
    for (int k = 0; k < plan->trajectory->Sample(tau).joints.size() && lost_at < 0.0; ++k) {
      const double sign = plan->trajectory->Sample(tau).joint_rates[k] >= 0.0 ? 1.0 : -1.0;
      bool fast = true;
      for (double s = tau; s <= tau + 0.7; s += 0.02) fast = fast && sign * plan->trajectory->Sample(s).joint_rates[k] >= 0.4;
      if (fast) lost_at = plan_start + tau + 0.3;
    }
  }
  ASSERT_GT(lost_at, 0.0) << "no fast joint on this plan";
  auto fly = [&](bool report_goals) {
    auto controller = MakeController(options);
    DirectFlight flight(controller.get());
    flight.set_report_goals(report_goals);
    flight.Run(40.0, [&](double t, sim::Simulator*) { flight.set_uplink_lost(t >= lost_at && t < lost_at + 0.25); });
    return std::make_pair(controller->joint_stalled(), flight.Events());
  };
  const auto [stalled, events] = fly(true);
  EXPECT_FALSE(stalled) << events;
  EXPECT_EQ(events.find("does not follow the plan"), std::string::npos) << events;
  const auto [stalled_blind, events_blind] = fly(false);
  EXPECT_TRUE(stalled_blind) << events_blind;
}

// Exact clearance of the robot at a planning start state (as Replan measures it).
double StateClearance(const Vec3& position, double yaw, const VecX& joints, double reach) {
  robot::KinematicsState kinematics;
  robot::ComputeKinematics(WindowCup().robot(), MakePose(position, Eigen::AngleAxisd(yaw, Vec3::UnitZ()).toRotationMatrix()),
                           joints, &kinematics);
  return env::WholeBodyClearance(kinematics, *WindowCup().exact, reach, {});
}

// A gust puts the vehicle 1 cm from a window edge (inside the 3 cm safety
// distance) as it approaches the window: the replan from there is attempted
// under the recovery rule, gets out, and the flight still reaches the cup.
TEST(OnlineControllerTest, AReplanFromInsideTheSafetyMarginGetsOutAndReachesTheCup) {
  // The vehicle is moved by resetting the simulator (a teleport no
  // velocity explains): followed as it is, not taken for an estimate jump.
  OnlineOptions options;
  options.shift_setpoints_on_jump = false;
  auto controller = MakeController(options);
  DirectFlight flight(controller.get());
  bool moved = false;
  double moved_by = 0.0, start_clearance = 1.0;
  flight.Run(40.0, [&](double t, sim::Simulator* sim) {
    if (moved || controller->phase() != Phase::kFlying || t - controller->current_plan_start() < 0.5) return;
    // The controller's replan start: the measured state predicted over the lead.
    const planner::WholeBodyTrajectory& plan = *controller->current_plan()->trajectory;
    const double now_time = t - controller->current_plan_start();
    const planner::WholeBodySample now = plan.Sample(now_time), then = plan.Sample(now_time + options.replan_lead);
    sim::VehicleState s = sim->state();
    const Vec3 delta = then.position - now.position;
    const double yaw = traj::HopfYawOf(s.attitude) + (then.yaw - now.yaw);
    const VecX joints = s.joints + (then.joints - now.joints);
    const Vec3 predicted = s.position + delta;
    // Wait until the vehicle approaches a window (within 15 cm)...
    if (StateClearance(predicted, yaw, joints, 0.3) > 0.15) return;
    // ...then move it towards the nearest edge until the start is 1 cm from it.
    Vec3 gradient;
    for (int k = 0; k < 3; ++k) {
      const Vec3 step = 1e-3 * Vec3::Unit(k);
      gradient[k] = (StateClearance(predicted + step, yaw, joints, 0.3) -
                     StateClearance(predicted - step, yaw, joints, 0.3)) / 2e-3;
    }
    const Vec3 towards = -gradient.normalized();
    double lo = 0.0, hi = 0.3;
    for (int i = 0; i < 40; ++i) {
      (StateClearance(predicted + 0.5 * (lo + hi) * towards, yaw, joints, 0.3) > 0.01 ? lo : hi) = 0.5 * (lo + hi);
    }
    start_clearance = StateClearance(predicted + lo * towards, yaw, joints, 0.3);
    moved_by = lo;
    s.position += lo * towards;
    sim->Reset(s, sim->time());
    moved = true;
  });
  ASSERT_TRUE(moved);
  EXPECT_NEAR(start_clearance, 0.01, 1e-3);
  EXPECT_GT(moved_by, options.replan_threshold);  // enough to trigger a replan
  const OnlineStats& stats = controller->stats();
  std::string plans;
  for (const PlanRecord& r : stats.plans) plans += std::string(planner::PlanStatusName(r.status)) + ": " + r.message + "\n";
  ASSERT_GE(stats.replans_triggered, 1);
  ASSERT_GE(stats.splices, 1) << plans;
  EXPECT_EQ(controller->phase(), Phase::kArrived) << plans;
  for (const PlanRecord& record : stats.plans) EXPECT_TRUE(record.success) << plans;
  // The first replan the push triggered (plans[0] is the first plan; the
  // periodic ones on track come before it) was a recovery.
  auto pushed = std::find_if(stats.plans.begin() + 1, stats.plans.end(),
                             [](const PlanRecord& r) { return r.replan && !r.periodic; });
  ASSERT_NE(pushed, stats.plans.end()) << plans;
  EXPECT_FALSE(pushed->cold_fallback);
  EXPECT_TRUE(pushed->recovery) << plans;
  EXPECT_NEAR(pushed->start_clearance, start_clearance, 2e-3);
  const FlightMetrics metrics = Metrics(flight.log(), *controller);
  EXPECT_LT(metrics.final_tool_error, 0.02);
  EXPECT_GT(metrics.min_clearance, 0.0) << "closest link " << metrics.closest_link;
}

TEST(OnlineControllerTest, AFailedReplanHoldsAtTheLastSafeSetpoint) {
  // The vehicle is moved by resetting the simulator (a teleport no
  // velocity explains): followed as it is, not taken for an estimate jump.
  OnlineOptions options;
  options.shift_setpoints_on_jump = false;
  auto controller = MakeController(options);
  DirectFlight flight(controller.get());
  bool moved = false;
  std::optional<Setpoint> before;
  flight.Run(20.0, [&](double t, sim::Simulator* sim) {
    if (!moved && controller->phase() == Phase::kFlying && t - controller->current_plan_start() > 1.0) {
      // Move the vehicle so that the replan's start (the measured state
      // predicted over the lead time) lies 1.5 cm from a scene point: a link
      // more than max_start_penetration (5 mm) inside the scene, in
      // collision. (At 3 cm a link is 3 mm inside: recovery is attempted.)
      const Vec3 delta = controller->Reference(t + options.replan_lead)->position - controller->Reference(t)->position;
      sim::VehicleState s = sim->state();
      const Vec3 predicted = s.position + delta;
      const std::vector<Vec3>& points = WindowCup().points;
      const Vec3 nearest = *std::min_element(points.begin(), points.end(), [&](const Vec3& a, const Vec3& b) {
        return (a - predicted).squaredNorm() < (b - predicted).squaredNorm();
      });
      s.position = nearest + 0.015 * (predicted - nearest).normalized() - delta;
      s.velocity.setZero();
      sim->Reset(s, sim->time());
      moved = true;
      before = controller->last_setpoint();
    }
  });
  ASSERT_TRUE(moved);
  EXPECT_EQ(controller->phase(), Phase::kHoldingAfterFailure);
  EXPECT_EQ(controller->hold_cause(), HoldCause::kPlanFailed);
  EXPECT_FALSE(controller->finished());
  ASSERT_FALSE(controller->stats().plans.empty());
  const PlanRecord& last = controller->stats().plans.back();
  EXPECT_TRUE(last.replan);
  EXPECT_FALSE(last.success);
  EXPECT_EQ(last.status, planner::PlanStatus::kStartInCollision) << last.message;
  // The hold: the plan's setpoint of the moment the replan failed, at rest.
  const ControllerOutput out = controller->Tick(flight.time());
  ASSERT_TRUE(out.setpoint.has_value());
  EXPECT_EQ(out.setpoint->velocity.norm(), 0.0);
  EXPECT_EQ(out.setpoint->acceleration.norm(), 0.0);
  ASSERT_TRUE(before.has_value());
  // It is no further from the setpoint streamed when the vehicle was moved than
  // the plan travels in the lead time before the failure was known.
  EXPECT_LT((out.setpoint->position - before->position).norm(), WindowCup().task.limits.v_max * 0.1);
  // The vehicle flew back to it.
  EXPECT_LT((flight.simulator().state().position - out.setpoint->position).norm(), 0.05);
}

// Continuous replanning: on track (no disturbance), a replan every
// replan_period s, each spliced in, and the flight still reaches the cup
// with the setpoints moving no faster than the plans and blends allow.
TEST(OnlineControllerTest, ReplansPeriodicallyOnTrackAndSplicesEachPlan) {
  OnlineOptions options;
  ASSERT_GT(options.replan_period, 0.0);
  auto controller = MakeController(options);
  DirectFlight flight(controller.get());
  flight.Run(40.0);
  const OnlineStats& stats = controller->stats();
  std::string plans;
  for (const PlanRecord& r : stats.plans) plans += std::string(planner::PlanStatusName(r.status)) + ": " + r.message + "\n";
  EXPECT_EQ(controller->phase(), Phase::kArrived) << plans;
  EXPECT_GE(stats.periodic_replans, 2) << plans;
  EXPECT_EQ(stats.periodic_replans, stats.replans_triggered) << "on track: no threshold replans";
  EXPECT_GE(stats.splices, 2) << plans;
  for (const PlanRecord& record : stats.plans) EXPECT_TRUE(record.success) << plans;
  const double bound = BlendStepBound(WindowCup().task.limits.v_max, options.replan_threshold, options.blend_window, 0.02);
  EXPECT_LE(stats.max_setpoint_step, bound);
  const FlightMetrics metrics = Metrics(flight.log(), *controller);
  EXPECT_LT(metrics.final_tool_error, 0.02);
  EXPECT_GT(metrics.min_clearance, 0.0) << "closest link " << metrics.closest_link;

  // Off, nothing is replanned on track.
  options.replan_period = 0.0;
  auto quiet = MakeController(options);
  DirectFlight quiet_flight(quiet.get());
  quiet_flight.Run(40.0);
  EXPECT_EQ(quiet->phase(), Phase::kArrived);
  EXPECT_EQ(quiet->stats().periodic_replans, 0);
}

// Our L-BFGS until told to fail; then every solve returns no usable point,
// so a replan fails without a contrived scene.
class FailingOnRequestSolver final : public opt::Solver {
 public:
  std::string name() const override { return "lbfgs, failing on request"; }
  bool available() const override { return true; }
  std::atomic<bool> fail{false};

 protected:
  void DoSolve(const opt::Objective& objective, const VecX& x0, const opt::SolverOptions& options,
               opt::SolveResult* result) const override {
    if (fail) {
      result->status = opt::SolveStatus::kEvaluationFailed;
      result->cost = std::numeric_limits<double>::quiet_NaN();
      result->message = "failing on request";
      return;
    }
    *result = inner_.Solve(objective, x0, options);
  }

 private:
  solvers::LbfgsSolver inner_;
};

// A periodic replan starts on track, so when it fails the current plan -
// certified, and still being flown - is kept: no hold, no cold plan.
TEST(OnlineControllerTest, AFailedPeriodicReplanKeepsFlyingTheCurrentPlan) {
  FailingOnRequestSolver solver;
  PlanningSetup setup = testing::Setup();
  setup.solver = &solver;
  auto created = OnlineController::Create(setup, OnlineOptions{});
  ASSERT_TRUE(created.ok()) << created.status().message();
  OnlineController* controller = created->get();
  DirectFlight flight(controller);
  flight.Run(40.0, [&](double, sim::Simulator*) {
    if (controller->phase() == Phase::kFlying) solver.fail = true;
  });
  const OnlineStats& stats = controller->stats();
  EXPECT_EQ(controller->phase(), Phase::kArrived);
  EXPECT_GE(stats.periodic_replans, 2);
  EXPECT_EQ(stats.splices, 0);
  int failed = 0;
  for (const PlanRecord& record : stats.plans) {
    if (!record.replan) continue;
    EXPECT_TRUE(record.periodic);
    EXPECT_FALSE(record.success);
    EXPECT_FALSE(record.cold_fallback);
    ++failed;
  }
  EXPECT_EQ(failed, stats.periodic_replans);
  EXPECT_LT(Metrics(flight.log(), *controller).final_tool_error, 0.02);
}

// A vehicle silent while flying is an outage for outage_timeout s (the
// controller holds and keeps streaming), then lost: nothing more is sent.
// With outage_timeout = vehicle_timeout, lost at once.
TEST(OnlineControllerTest, ASilentVehicleStopsTheStream) {
  for (double outage_timeout : {0.5, 2.0}) {
    OnlineOptions options;
    options.vehicle_timeout = 0.5;
    options.outage_timeout = outage_timeout;
    auto controller = MakeController(options);
    DirectFlight flight(controller.get());
    double silent_from = -1.0;
    bool streamed_in_outage = false;
    flight.Run(20.0, [&](double t, sim::Simulator*) {
      if (silent_from < 0.0 && controller->phase() == Phase::kFlying && t - controller->current_plan_start() > 1.0) {
        silent_from = t;
        flight.set_silent(true);
      }
      if (silent_from >= 0.0 && t - silent_from > options.vehicle_timeout + 0.1 &&
          controller->phase() == Phase::kFlying) {
        streamed_in_outage = true;
      }
    });
    ASSERT_GE(silent_from, 0.0);
    EXPECT_EQ(controller->phase(), Phase::kVehicleLost);
    EXPECT_TRUE(controller->finished());
    // Declared lost within one 20 ms period after the time-out.
    EXPECT_LE(flight.time() - silent_from, outage_timeout + 0.02 + 0.02 + 1e-9) << outage_timeout;
    EXPECT_GE(flight.time() - silent_from, outage_timeout) << outage_timeout;
    EXPECT_EQ(streamed_in_outage, outage_timeout > options.vehicle_timeout + 0.2) << outage_timeout;
    const ControllerOutput out = controller->Tick(flight.time() + 0.02);
    EXPECT_FALSE(out.setpoint.has_value());
    EXPECT_TRUE(out.commands.empty());
  }
}

// --------------------------------------------------------------- handshake

// A vehicle at rest at the task's start that never moves; the test answers.
class HandshakeTest : public ::testing::Test {
 protected:
  void SetUp() override { controller_ = MakeController(options_); }

  ControllerOutput TickAt(double t) {
    const planner::Task& task = WindowCup().task;
    controller_->OnPosition(t, task.start.position, Vec3::Zero());
    controller_->OnAttitude(t, Quat(Eigen::AngleAxisd(task.start.yaw, Vec3::UnitZ())), Vec3::Zero());
    controller_->OnJoints(t, task.start.joints, VecX::Zero(task.start.joints.size()));
    ControllerOutput out = controller_->Tick(t);
    testing::AnswerTimesync(controller_.get(), out, t);
    return out;
  }

  // Ticks at 50 Hz from `from` to `to`; returns the commands sent with their times.
  std::vector<std::pair<double, CommandRequest>> Run(double from, double to,
                                                     const std::function<void(double, const CommandRequest&)>& answer) {
    std::vector<std::pair<double, CommandRequest>> sent;
    for (double t = from; t < to - 1e-9; t += 0.02) {
      const ControllerOutput out = TickAt(t);
      for (const CommandRequest& c : out.commands) {
        sent.emplace_back(t, c);
        if (answer) answer(t, c);
      }
    }
    return sent;
  }

  // The positions these tests give jump (a vehicle placed, not flown):
  // followed as they are, not taken for estimate jumps.
  OnlineOptions options_ = [] {
    OnlineOptions o;
    o.shift_setpoints_on_jump = false;
    return o;
  }();
  std::unique_ptr<OnlineController> controller_;
};

TEST_F(HandshakeTest, RetriesATemporarilyRejectedModeChangeThenArms) {
  int rejections = 0;
  const auto sent = Run(0.0, 5.0, [&](double t, const CommandRequest& c) {
    if (c.command == Command::kSetOffboardMode && rejections < 2) {
      ++rejections;
      controller_->OnCommandAck(t, c.command, AckResult::kTemporarilyRejected);
    } else {
      controller_->OnCommandAck(t, c.command, AckResult::kAccepted);
    }
  });
  ASSERT_EQ(sent.size(), 4u);
  EXPECT_GE(sent[0].first, options_.hold_time);  // the hold streamed first
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(sent[i].second.command, Command::kSetOffboardMode);
    EXPECT_EQ(sent[i].second.attempt, i);
  }
  EXPECT_NEAR(sent[1].first - sent[0].first, options_.ack_timeout, 0.021);
  EXPECT_EQ(sent[3].second.command, Command::kArm);
  EXPECT_EQ(sent[3].second.attempt, 0);
  controller_->WaitUntilIdle();
  TickAt(5.0);
  EXPECT_TRUE(controller_->phase() == Phase::kFlying || controller_->phase() == Phase::kArrived)
      << PhaseName(controller_->phase());
}

TEST_F(HandshakeTest, GivesUpWithoutAcknowledgements) {
  const auto sent = Run(0.0, 6.0, nullptr);
  ASSERT_EQ(static_cast<int>(sent.size()), options_.max_command_attempts);
  for (int i = 0; i < options_.max_command_attempts; ++i) EXPECT_EQ(sent[i].second.attempt, i);
  EXPECT_EQ(controller_->phase(), Phase::kHandshakeFailed);
  EXPECT_TRUE(controller_->finished());
  EXPECT_FALSE(TickAt(6.0).setpoint.has_value());
}

TEST_F(HandshakeTest, ARefusedArmingEndsTheFlight) {
  Run(0.0, 3.0, [&](double t, const CommandRequest& c) {
    controller_->OnCommandAck(t, c.command,
                              c.command == Command::kArm ? AckResult::kRejected : AckResult::kAccepted);
  });
  EXPECT_EQ(controller_->phase(), Phase::kHandshakeFailed);
}

TEST_F(HandshakeTest, AHeartbeatShowingTheModeCountsAsConfirmation) {
  const auto sent = Run(0.0, 3.0, [&](double t, const CommandRequest&) {
    controller_->OnHeartbeat(t, /*armed=*/true, /*offboard=*/true);  // acknowledgements lost
  });
  EXPECT_EQ(sent.size(), 1u);  // one mode request; the heartbeat then shows both
  EXPECT_NE(controller_->phase(), Phase::kRequestingOffboard);
  EXPECT_NE(controller_->phase(), Phase::kArming);
  EXPECT_NE(controller_->phase(), Phase::kHandshakeFailed);
}

TEST_F(HandshakeTest, TheFlightStartsOnceTheVehicleHasSettledAtTheHold) {
  // Handshake done at once, plan ready.
  Run(0.0, 1.5, [&](double t, const CommandRequest& c) { controller_->OnCommandAck(t, c.command, AckResult::kAccepted); });
  controller_->WaitUntilIdle();
  ASSERT_EQ(controller_->phase(), Phase::kWaitingForPlan);
  const planner::Task& task = WindowCup().task;
  const Quat attitude(Eigen::AngleAxisd(task.start.yaw, Vec3::UnitZ()));
  // 5 cm away from the hold (still following its own hold, say): no start...
  double t = 1.5;
  // (Arming was confirmed at about 1.24 s; the settle time-out is 3 s.)
  for (; t < 1.2 + options_.settle_timeout - 0.1; t += 0.02) {
    controller_->OnPosition(t, task.start.position + Vec3(0.05, 0.0, 0.0), Vec3::Zero());
    controller_->OnAttitude(t, attitude, Vec3::Zero());
    controller_->OnJoints(t, task.start.joints, VecX::Zero(3));
    const ControllerOutput out = controller_->Tick(t);
    testing::AnswerTimesync(controller_.get(), out, t);
    ASSERT_EQ(out.phase, Phase::kWaitingForPlan) << t;
    ASSERT_TRUE(out.setpoint.has_value());
    EXPECT_LT((out.setpoint->position - task.start.position).norm(), 1e-9);  // the hold
  }
  // ...until it comes within start_tolerance.
  EXPECT_EQ(TickAt(t).phase, Phase::kFlying);
}

TEST_F(HandshakeTest, NoVehicleMeansNoStream) {
  for (double t = 0.0; t < 1.0; t += 0.02) {
    const ControllerOutput out = controller_->Tick(t);
    EXPECT_FALSE(out.setpoint.has_value());
    EXPECT_TRUE(out.commands.empty());
  }
  EXPECT_EQ(controller_->phase(), Phase::kWaitingForVehicle);
  controller_->Tick(options_.connect_timeout + 0.1);
  EXPECT_EQ(controller_->phase(), Phase::kVehicleLost);
}

}  // namespace
}  // namespace quadhand::online
