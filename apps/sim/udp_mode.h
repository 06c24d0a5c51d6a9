// quadhand-sim --udp: the socket loop around sim::Autopilot (docs/sim.md,
// "MAVLink mode").
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "quadhand/link/frame.h"
#include "quadhand/link/udp.h"
#include "quadhand/robot/robot_model.h"
#include "quadhand/sim/autopilot.h"
#include "quadhand/sim/sensor.h"

namespace quadhand::sim_app {

struct UdpModeOptions {
  link::UdpEndpoint bind;                    // where the simulated autopilot listens
  std::optional<link::UdpEndpoint> remote;   // fixed peer; default: the sender of the first accepted frame
  bool realtime = false;                     // pace simulated time to the wall clock
  double duration = 0.0;                     // simulated s; 0: until SIGINT/SIGTERM
  std::string log_path;                      // flown states (plan columns), empty: none
  std::optional<link::SigningKey> signing_key;
  bool require_signing = false;
  uint8_t system_id = 1;
  bool quiet = false;
  // Lockstep (no --realtime): each SET_POSITION_TARGET_LOCAL_NED advances
  // simulated time by `lockstep_period`; after `lockstep_idle` s of wall time
  // without one, simulated time follows the wall clock.
  double lockstep_period = 0.02;
  double lockstep_idle = 0.1;
  // A sensor on the vehicle (sim/sensor.h): every 1 / rate s of simulated
  // time a frame rendered from the true state goes to `frames_to` as
  // sensor-stream chunks (link/sensor_stream.h), stamped with the vehicle's
  // clock. None without a renderer.
  sim::SensorRenderer* renderer = nullptr;
  sim::SensorConfig sensor;
  const robot::RobotModel* robot = nullptr;  // for the sensor link's pose
  link::UdpEndpoint frames_to;
  int miss_stride = 8;              // every this-many-th pixel's miss along each axis goes too
  size_t frame_datagram = 60000;    // bytes per chunk at most
};

// Runs until the duration is reached or a signal arrives; returns the exit
// code (0 done, 1 the simulation diverged, 2 the socket or the log could not
// be used), having printed one error line when it is not 0.
int RunUdpMode(sim::Autopilot autopilot, const UdpModeOptions& options, const std::vector<std::string>& joint_names);

}  // namespace quadhand::sim_app
