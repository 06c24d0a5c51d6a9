// Plan files, the figure-eight plan, the configuration file, and TrackPlan.
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "quadhand/sim/figure_eight.h"
#include "quadhand/sim/plan_io.h"
#include "quadhand/sim/simulator.h"
#include "sim/sim_test_util.h"

namespace quadhand::sim {
namespace {

using testing::Config;
using testing::Model;
using testing::Robot;

const std::vector<std::string> kJoints = {"joint1", "joint2", "joint3"};

// A plan hovering at (0, 0, 1) while joint1 moves linearly from 0.2 to 0.4.
std::string SmallPlan() {
  Plan plan;
  plan.joint_names = kJoints;
  for (int k = 0; k <= 10; ++k) {
    PlanRow r;
    r.t = 0.1 * k;
    r.position = Vec3(0, 0, 1);
    r.yaw = 3.1;
    r.attitude = Quat(Eigen::AngleAxisd(3.1, Vec3::UnitZ()));
    r.joints = VecX::Zero(3);
    r.joints[0] = 0.2 + 0.02 * k;
    r.joint_rates = VecX::Zero(3);
    r.joint_rates[0] = 0.2;
    plan.rows.push_back(r);
  }
  return WritePlanCsv(plan);
}

void ExpectError(const std::string& text, const std::string& fragment) {
  auto plan = ParsePlanCsv(text, kJoints, "p.csv");
  ASSERT_FALSE(plan.ok());
  EXPECT_EQ(plan.status().code(), core::StatusCode::kInvalidArgument);
  EXPECT_EQ(plan.status().message().rfind("p.csv: ", 0), 0u) << plan.status().message();
  EXPECT_NE(plan.status().message().find(fragment), std::string::npos) << plan.status().message();
}

TEST(PlanIoTest, RoundTripsAndFindsColumnsByName) {
  const std::string text = SmallPlan();
  EXPECT_EQ(text.substr(0, text.find('\n')),
            "t,px,py,pz,vx,vy,vz,ax,ay,az,qw,qx,qy,qz,yaw,yaw_rate,joint1,joint2,joint3,joint1_rate,joint2_rate,"
            "joint3_rate");
  auto plan = ParsePlanCsv(text, kJoints, "p.csv");
  ASSERT_TRUE(plan.ok()) << plan.status().message();
  ASSERT_EQ(plan->rows.size(), 11u);
  EXPECT_NEAR(plan->rows[5].joints[0], 0.3, 1e-12);
  EXPECT_EQ(WritePlanCsv(*plan), text);
  // Extra columns are ignored, whatever their place.
  auto extra = ParsePlanCsv("note,t,px,py,pz,vx,vy,vz,ax,ay,az,qw,qx,qy,qz,yaw,yaw_rate,joint1,joint2,joint3,"
                            "joint1_rate,joint2_rate,joint3_rate\n"
                            "x,0,0,0,1,0,0,0,0,0,0,1,0,0,0,0,0,0.1,0,0,0,0,0\n"
                            "y,1,0,0,1,0,0,0,0,0,0,1,0,0,0,0,0,0.2,0,0,0,0,0\n",
                            kJoints, "p.csv");
  ASSERT_TRUE(extra.ok()) << extra.status().message();
  EXPECT_NEAR(extra->rows[1].joints[0], 0.2, 1e-15);
  // A mission's gripper column comes back; a subnormal rate (a simulator's
  // joint coming to rest) is a finite number, an overflow is not.
  auto mission = ParsePlanCsv("t,px,py,pz,vx,vy,vz,ax,ay,az,qw,qx,qy,qz,yaw,yaw_rate,joint1,joint2,joint3,"
                              "joint1_rate,joint2_rate,joint3_rate,gripper\n"
                              "0,0,0,1,0,0,0,0,0,0,1,0,0,0,0,0,0.1,0,0,0,1.552353207e-308,0,0\n"
                              "1,0,0,1,0,0,0,0,0,0,1,0,0,0,0,0,0.2,0,0,0,0,-5.1e-309,1\n",
                              kJoints, "p.csv");
  ASSERT_TRUE(mission.ok()) << mission.status().message();
  EXPECT_EQ(mission->rows[0].gripper, 0);
  EXPECT_EQ(mission->rows[1].gripper, 1);
  EXPECT_GT(mission->rows[0].joint_rates[1], 0.0);
  EXPECT_EQ(WritePlanCsv(*mission).substr(0, 5), "t,px,");
  EXPECT_NE(WritePlanCsv(*mission).find("joint3_rate,gripper\n"), std::string::npos);
  EXPECT_EQ(plan->rows[0].gripper, -1);
}

// An online flight log's target is blank until its tracker's first
// estimate: such a row has no target; a row with some of the seven cells
// blank is refused, and blank cells elsewhere stay errors.
TEST(PlanIoTest, ReadsBlankTargetsAsNoTarget) {
  const std::string header =
      "t,px,py,pz,vx,vy,vz,ax,ay,az,qw,qx,qy,qz,yaw,yaw_rate,joint1,joint2,joint3,joint1_rate,joint2_rate,"
      "joint3_rate,target_x,target_y,target_z,target_qw,target_qx,target_qy,target_qz\n";
  const std::string blank_row = "0,0,0,1,0,0,0,0,0,0,1,0,0,0,0,0,0.1,0,0,0,0,0,,,,,,,\n";
  const std::string target_row = "1,0,0,1,0,0,0,0,0,0,1,0,0,0,0,0,0.1,0,0,0,0,0,2,3,4,1,0,0,0\n";
  auto plan = ParsePlanCsv(header + blank_row + target_row, kJoints, "p.csv");
  ASSERT_TRUE(plan.ok()) << plan.status().message();
  EXPECT_TRUE(plan->has_target_columns);
  EXPECT_FALSE(plan->rows[0].target.has_value());
  ASSERT_TRUE(plan->rows[1].target.has_value());
  // A log whose target was never estimated still has the columns.
  auto never = ParsePlanCsv(header + blank_row + "1,0,0,1,0,0,0,0,0,0,1,0,0,0,0,0,0.1,0,0,0,0,0,,,,,,,\n", kJoints, "p.csv");
  ASSERT_TRUE(never.ok()) << never.status().message();
  EXPECT_TRUE(never->has_target_columns);
  EXPECT_FALSE(never->rows[1].target.has_value());
  EXPECT_FALSE(ParsePlanCsv(SmallPlan(), kJoints, "p.csv")->has_target_columns);
  EXPECT_EQ(plan->rows[1].target->translation(), Vec3(2, 3, 4));
  ExpectError(header + "0,0,0,1,0,0,0,0,0,0,1,0,0,0,0,0,0.1,0,0,0,0,0,2,,4,1,0,0,0\n" + target_row,
              "row 1: target_x..target_qz: all seven blank");
  ExpectError(header + "0,0,0,1,0,0,0,0,0,0,1,0,0,0,0,0,,0,0,0,0,0,,,,,,,\n" + target_row, "column 'joint1'");
}

TEST(PlanIoTest, RejectsMalformedPlans) {
  const std::string text = SmallPlan();
  const std::string header = text.substr(0, text.find('\n') + 1);
  ExpectError("", "empty");
  ExpectError(header.substr(0, header.find(",joint2,")) + "\n", "missing column 'joint2'");
  ExpectError(header + "0,0,0,1,0,0,0,0,0,0,1,0,0,0,0,0,0.1,0,0,0,0\n", "line 2");
  ExpectError(header + "0,0,0,1,0,0,0,0,0,0,1,0,0,0,0,0,0.1,0,0,0,0,0\n"
                       "0.1,0,0,abc,0,0,0,0,0,0,1,0,0,0,0,0,0.1,0,0,0,0,0\n",
              "line 3: column 'pz'");
  ExpectError(header + "0,0,0,1,0,0,0,0,0,0,1,0,0,0,0,0,nan,0,0,0,0,0\n", "column 'joint1'");
  ExpectError(header + "0,0,0,1,0,0,0,0,0,0,1,0,0,0,0,0,1e309,0,0,0,0,0\n", "column 'joint1'");
  ExpectError(std::string("t,px,py,pz,vx,vy,vz,ax,ay,az,qw,qx,qy,qz,yaw,yaw_rate,joint1,joint2,joint3,joint1_rate,"
                          "joint2_rate,joint3_rate,gripper\n") +
                  "0,0,0,1,0,0,0,0,0,0,1,0,0,0,0,0,0.1,0,0,0,0,0,0.5\n"
                  "1,0,0,1,0,0,0,0,0,0,1,0,0,0,0,0,0.1,0,0,0,0,0,1\n",
              "column 'gripper': must be 0 (open) or 1 (closed)");
  ExpectError(header + "0,0,0,1,0,0,0,0,0,0,1,0,0,0,0,0,0.1,0,0,0,0,0\n"
                       "0,0,0,1,0,0,0,0,0,0,1,0,0,0,0,0,0.1,0,0,0,0,0\n",
              "does not increase");
  ExpectError(header + "0,0,0,1,0,0,0,0,0,0,2,0,0,0,0,0,0.1,0,0,0,0,0\n", "unit length");
  ExpectError(header + "0,0,0,1,0,0,0,0,0,0,1,0,0,0,0,0,0.1,0,0,0,0,0\n", "at least 2 rows");
}

TEST(PlanIoTest, SamplesBetweenRows) {
  Plan plan;
  plan.joint_names = kJoints;
  for (int k = 0; k < 2; ++k) {
    PlanRow r;
    r.t = 1.0 + k;
    r.position = Vec3(k, 2 * k, 1);
    r.acceleration = Vec3(0, 0, 3 * k);
    r.yaw = k == 0 ? 3.0 : -3.0;  // across +-pi: along the shorter arc
    r.joints = VecX::Constant(3, k);
    r.joint_rates = VecX::Zero(3);
    plan.rows.push_back(r);
  }
  const Setpoint sp = SamplePlan(plan, 1.25);
  EXPECT_LT((sp.position - Vec3(0.25, 0.5, 1)).norm(), 1e-12);
  EXPECT_LT((sp.jerk - Vec3(0, 0, 3)).norm(), 1e-12);
  EXPECT_NEAR(std::remainder(sp.yaw - (3.0 + 0.25 * (2 * M_PI - 6.0)), 2 * M_PI), 0.0, 1e-12);
  EXPECT_NEAR(sp.joints[1], 0.25, 1e-12);
  EXPECT_LT((SamplePlan(plan, 5.0).position - Vec3(1, 2, 1)).norm(), 1e-12);
  EXPECT_LT((SamplePlan(plan, 0.0).position - Vec3(0, 0, 1)).norm(), 1e-12);
}

TEST(FigureEightTest, IsTheExperimentsShapeAndStartsAndEndsAtRest) {
  const robot::RobotModel& robot = Robot();
  FigureEightOptions o;
  auto plan = MakeFigureEightPlan(o, robot.ActuatedJointNames(), robot.LowerLimits(), robot.UpperLimits(),
                                  robot.VelocityLimits());
  ASSERT_TRUE(plan.ok()) << plan.status().message();
  EXPECT_NEAR(plan->end_time(), o.loops * o.period + o.ramp, 1e-12);
  Vec3 lo = Vec3::Constant(1e9), hi = Vec3::Constant(-1e9);
  for (const PlanRow& r : plan->rows) {
    lo = lo.cwiseMin(r.position);
    hi = hi.cwiseMax(r.position);
    for (int k = 0; k < 3; ++k) {
      EXPECT_GE(r.joints[k], robot.LowerLimits()[k] - 1e-12);
      EXPECT_LE(r.joints[k], robot.UpperLimits()[k] + 1e-12);
    }
  }
  EXPECT_NEAR(hi.x() - lo.x(), 3.6, 1e-3);
  EXPECT_NEAR(hi.y() - lo.y(), 2.0, 1e-3);
  EXPECT_NEAR(hi.z() - lo.z(), 0.0, 1e-12);
  for (const PlanRow* r : {&plan->rows.front(), &plan->rows.back()}) {
    EXPECT_LT(r->velocity.norm(), 1e-9);
    EXPECT_LT(r->acceleration.norm(), 1e-9);
    EXPECT_LT(r->joint_rates.norm(), 1e-9);
  }
  EXPECT_LT((plan->rows.back().position - plan->rows.front().position).norm(), 1e-9);  // closed loops
  // Velocity and acceleration are the derivatives of position and velocity.
  const std::vector<PlanRow>& rows = plan->rows;
  for (size_t i = 1; i + 1 < rows.size(); i += 37) {
    const double h = rows[i + 1].t - rows[i - 1].t;
    EXPECT_LT(((rows[i + 1].position - rows[i - 1].position) / h - rows[i].velocity).norm(), 1e-3);
    EXPECT_LT(((rows[i + 1].velocity - rows[i - 1].velocity) / h - rows[i].acceleration).norm(), 1e-3);
    EXPECT_NEAR((rows[i + 1].joints[0] - rows[i - 1].joints[0]) / h, rows[i].joint_rates[0], 1e-3);
  }
  // Joint motion beyond the limits is refused.
  o.joint_amplitude[0] = 1.0;
  EXPECT_FALSE(MakeFigureEightPlan(o, robot.ActuatedJointNames(), robot.LowerLimits(), robot.UpperLimits(),
                                   robot.VelocityLimits())
                   .ok());
}

TEST(SimConfigTest, ShippedFileLoadsAndTyposAreErrors) {
  auto config = LoadSimConfig(testing::kConfigPath);
  ASSERT_TRUE(config.ok()) << config.status().message();
  EXPECT_EQ(config->step, 0.001);
  EXPECT_EQ(config->rotors.wheelbase, 0.33);
  EXPECT_EQ(config->payload.mass, 0.15);
  EXPECT_NE(config->robot_path.find("quadhand.urdf"), std::string::npos);

  auto typo = ParseSimConfig("rotors:\n  max_trust: 9\n", ".", "c.yaml");
  ASSERT_FALSE(typo.ok());
  EXPECT_NE(typo.status().message().find("c.yaml: rotors.max_trust: unknown key"), std::string::npos)
      << typo.status().message();
  auto slow = ParseSimConfig("step: 0.01\n", ".", "c.yaml");
  ASSERT_FALSE(slow.ok());
  EXPECT_NE(slow.status().message().find("500 Hz"), std::string::npos);
  EXPECT_FALSE(ParseSimConfig("step: [1, 2\n", ".", "c.yaml").ok());
  EXPECT_FALSE(ParseSimConfig("gravity: abc\n", ".", "c.yaml").ok());
  // Numbers out of their documented ranges (docs/sim.md): a simulation with
  // them diverges or flies something meaningless, so they are refused.
  for (const auto& [text, fragment] : std::vector<std::pair<std::string, std::string>>{
           {"gravity: 1e300\n", "gravity must be in [0, 100]"},
           {"rotors: {wheelbase: 1e300}\n", "rotors.wheelbase must be in (0, 10] m"},
           {"rotors: {max_thrust: 1e300}\n", "rotors: need 0 <= min_thrust < max_thrust <= 10000 N"},
           {"rotors: {time_constant: 1e-300}\n", "rotors.time_constant must be 0 or in [step / 2, 10] s"},
           {"servo: {time_constant: 1e-9}\n", "servo.time_constant"},
           {"linear_drag: [1e300, 0, 0]\n", "linear_drag"},
           {"payload: {offset: [1e300, 0, 0]}\n", "payload.offset"},
           {"controller: {position_gain: [1e300, 8, 8]}\n", "controller gains"},
           {"controller: {inertia: [1e300, 0, 0]}\n", "controller mass and inertia"},
           {"controller: {position_integral_limit: 1e300}\n", "controller integral limits"},
           {"noise: {position: 1e300}\n", "noise standard deviations"},
           {"servo: {max_acceleration: [1e300, 30, 60]}\n", "servo.max_acceleration"}}) {
    auto parsed = ParseSimConfig(text, ".", "c.yaml");
    ASSERT_FALSE(parsed.ok()) << text;
    EXPECT_NE(parsed.status().message().find("c.yaml: " + fragment), std::string::npos) << parsed.status().message();
  }
  EXPECT_TRUE(ParseSimConfig("rotors: {time_constant: 0}\n", ".", "c.yaml").ok());
  EXPECT_FALSE(LoadSimConfig("/nonexistent/sim.yaml").ok());

  SimConfig c = Config();
  c.pcgc_joint = "joint1";  // not a mimic joint
  EXPECT_FALSE(VehicleModel::Create(Robot(), c).ok());
  c = Config();
  c.servo.max_acceleration = {1.0};
  EXPECT_FALSE(VehicleModel::Create(Robot(), c).ok());
}

TEST(TrackPlanTest, FliesASmallPlanAndRecordsEveryRow) {
  auto plan = ParsePlanCsv(SmallPlan(), kJoints, "p.csv");
  ASSERT_TRUE(plan.ok());
  Simulator sim(Model(true, 0.0), 1);
  TrackOptions options;
  options.settle = 2.0;
  auto result = TrackPlan(&sim, *plan, options);
  ASSERT_TRUE(result.ok()) << result.status().message();
  ASSERT_EQ(result->samples.size(), plan->rows.size());
  for (size_t i = 0; i < plan->rows.size(); ++i) {
    EXPECT_NEAR(result->samples[i].flown.t, plan->rows[i].t, 1e-12);
    EXPECT_LT(result->samples[i].position_error.norm(), 0.02);
    EXPECT_LT(std::abs(result->samples[i].yaw_error), 0.02);
  }
  EXPECT_NEAR(result->samples.back().flown.joints[0], 0.4, 0.02);
  EXPECT_NEAR(result->simulated_s, 3.0, 1e-12);
  const std::string csv = FlownCsv(result->samples, kJoints);
  EXPECT_NE(csv.find(",err_x,err_y,err_z,err_pos,err_yaw,cog_x"), std::string::npos);
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 12);
  // The flown file is itself a readable plan.
  EXPECT_TRUE(ParsePlanCsv(csv, kJoints, "flown.csv").ok());
}

}  // namespace
}  // namespace quadhand::sim
