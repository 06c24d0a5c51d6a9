// Shared helpers of the simulator tests: the reference robot and configuration.
#pragma once

#include <string>

#include <gtest/gtest.h>

#include "quadhand/robot/robot_model.h"
#include "quadhand/sim/config.h"
#include "quadhand/sim/vehicle_model.h"

namespace quadhand::sim::testing {

inline const std::string kRoot = QUADHAND_SOURCE_DIR;
inline const std::string kConfigPath = kRoot + "/data/sim/quadhand_sim.yaml";

inline const robot::RobotModel& Robot() {
  static const robot::RobotModel robot = *robot::RobotModel::LoadFromUrdfFile(kRoot + "/meshes/quadhand/quadhand.urdf");
  return robot;
}

// The shipped configuration with noise off.
inline SimConfig Config() {
  auto config = LoadSimConfig(kConfigPath);
  EXPECT_TRUE(config.ok()) << config.status().message();
  SimConfig c = *config;
  c.noise.enabled = false;
  return c;
}

inline VehicleModel Model(const SimConfig& config) {
  auto model = VehicleModel::Create(Robot(), config);
  EXPECT_TRUE(model.ok()) << model.status().message();
  return *model;
}

inline VehicleModel Model(bool pcgc, double payload) {
  SimConfig c = Config();
  c.pcgc = pcgc;
  c.payload.attached = payload > 0.0;
  c.payload.mass = payload;
  return Model(c);
}

inline VecX Joints(double q1, double q2, double q3) {
  VecX q(3);
  q << q1, q2, q3;
  return q;
}

}  // namespace quadhand::sim::testing
