// One of each link message with every field set (tests/link only), and a
// JSON view of a message keyed by the common.xml field names, for comparing
// with the node-mavlink peer.
#pragma once

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

#include "quadhand/link/messages.h"

namespace quadhand::link::link_testing {

inline std::vector<Message> SampleMessages() {
  Heartbeat heartbeat;
  heartbeat.custom_mode = mav::Px4CustomMode(mav::kPx4MainModeOffboard);
  heartbeat.type = mav::kTypeQuadrotor;
  heartbeat.autopilot = mav::kAutopilotPx4;
  heartbeat.base_mode = mav::kModeFlagCustomModeEnabled | mav::kModeFlagSafetyArmed;
  heartbeat.system_status = mav::kStateActive;
  AttitudeQuaternion attitude;
  attitude.time_boot_ms = 123456;
  attitude.q1 = 0.5f;
  attitude.q2 = -0.5f;
  attitude.q3 = 0.5f;
  attitude.q4 = -0.5f;
  attitude.rollspeed = 0.1f;
  attitude.pitchspeed = -0.2f;
  attitude.yawspeed = 0.3f;
  attitude.repr_offset_q = {1.0f, 0.0f, 0.0f, 0.25f};
  LocalPositionNed position;
  position.time_boot_ms = 4000000000u;
  position.x = 1.5f;
  position.y = -2.25f;
  position.z = -3.0f;
  position.vx = 0.125f;
  position.vy = -0.5f;
  position.vz = 0.75f;
  CommandLong command;
  command.command = mav::kCmdDoSetMode;
  command.param1 = 1;
  command.param2 = 6;
  command.param3 = 0.3f;
  command.param4 = -4;
  command.param5 = 5e6f;
  command.param6 = -6e-6f;
  command.param7 = -7.5f;
  command.target_system = 1;
  command.target_component = 1;
  command.confirmation = 2;
  CommandAck ack;
  ack.command = mav::kCmdComponentArmDisarm;
  ack.result = mav::kResultDenied;
  ack.progress = 100;
  ack.result_param2 = -42;
  ack.target_system = 255;
  ack.target_component = 190;
  SetPositionTargetLocalNed setpoint;
  setpoint.time_boot_ms = 77;
  setpoint.x = 1;
  setpoint.y = 2;
  setpoint.z = -3;
  setpoint.vx = 0.1f;
  setpoint.vy = 0.2f;
  setpoint.vz = 0.3f;
  setpoint.afx = -0.1f;
  setpoint.afy = -0.2f;
  setpoint.afz = -0.3f;
  setpoint.yaw = 1.25f;
  setpoint.yaw_rate = -0.5f;
  setpoint.type_mask = 0x0C00;
  setpoint.target_system = 1;
  setpoint.target_component = 1;
  StatusText text;
  text.severity = 4;
  text.text = "Offboard lost: holding position";
  text.id = 3;
  text.chunk_seq = 1;
  DebugFloatArray joints;
  joints.time_usec = 1234567890123ULL;
  joints.array_id = 1;
  joints.name = "JOINTS";
  joints.data = {0.1f, -0.2f, 0.3f, 0.4f};
  return {heartbeat, attitude, position, command, ack, setpoint, text, joints};
}

// {"name": "HEARTBEAT", "fields": {...}}: floats as the doubles they are,
// uint64 as decimal strings, arrays at their full wire length.
inline nlohmann::json ToJson(const Message& message) {
  using nlohmann::json;
  auto f = [](float v) { return static_cast<double>(v); };
  json fields;
  std::string name;
  if (const auto* m = std::get_if<Heartbeat>(&message)) {
    name = "HEARTBEAT";
    fields = {{"custom_mode", m->custom_mode}, {"type", m->type}, {"autopilot", m->autopilot},
              {"base_mode", m->base_mode}, {"system_status", m->system_status},
              {"mavlink_version", m->mavlink_version}};
  } else if (const auto* a = std::get_if<AttitudeQuaternion>(&message)) {
    name = "ATTITUDE_QUATERNION";
    json repr = json::array();
    for (float v : a->repr_offset_q) repr.push_back(f(v));
    fields = {{"time_boot_ms", a->time_boot_ms}, {"q1", f(a->q1)}, {"q2", f(a->q2)}, {"q3", f(a->q3)},
              {"q4", f(a->q4)}, {"rollspeed", f(a->rollspeed)}, {"pitchspeed", f(a->pitchspeed)},
              {"yawspeed", f(a->yawspeed)}, {"repr_offset_q", repr}};
  } else if (const auto* p = std::get_if<LocalPositionNed>(&message)) {
    name = "LOCAL_POSITION_NED";
    fields = {{"time_boot_ms", p->time_boot_ms}, {"x", f(p->x)}, {"y", f(p->y)}, {"z", f(p->z)},
              {"vx", f(p->vx)}, {"vy", f(p->vy)}, {"vz", f(p->vz)}};
  } else if (const auto* c = std::get_if<CommandLong>(&message)) {
    name = "COMMAND_LONG";
    fields = {{"param1", f(c->param1)}, {"param2", f(c->param2)}, {"param3", f(c->param3)},
              {"param4", f(c->param4)}, {"param5", f(c->param5)}, {"param6", f(c->param6)},
              {"param7", f(c->param7)}, {"command", c->command}, {"target_system", c->target_system},
              {"target_component", c->target_component}, {"confirmation", c->confirmation}};
  } else if (const auto* k = std::get_if<CommandAck>(&message)) {
    name = "COMMAND_ACK";
    fields = {{"command", k->command}, {"result", k->result}, {"progress", k->progress},
              {"result_param2", k->result_param2}, {"target_system", k->target_system},
              {"target_component", k->target_component}};
  } else if (const auto* s = std::get_if<SetPositionTargetLocalNed>(&message)) {
    name = "SET_POSITION_TARGET_LOCAL_NED";
    fields = {{"time_boot_ms", s->time_boot_ms}, {"x", f(s->x)}, {"y", f(s->y)}, {"z", f(s->z)},
              {"vx", f(s->vx)}, {"vy", f(s->vy)}, {"vz", f(s->vz)}, {"afx", f(s->afx)},
              {"afy", f(s->afy)}, {"afz", f(s->afz)}, {"yaw", f(s->yaw)}, {"yaw_rate", f(s->yaw_rate)},
              {"type_mask", s->type_mask}, {"target_system", s->target_system},
              {"target_component", s->target_component}, {"coordinate_frame", s->coordinate_frame}};
  } else if (const auto* t = std::get_if<StatusText>(&message)) {
    name = "STATUSTEXT";
    fields = {{"severity", t->severity}, {"text", t->text.substr(0, 50)}, {"id", t->id}, {"chunk_seq", t->chunk_seq}};
  } else if (const auto* d = std::get_if<DebugFloatArray>(&message)) {
    name = "DEBUG_FLOAT_ARRAY";
    json data = json::array();
    for (int i = 0; i < DebugFloatArray::kMaxData; ++i) {
      data.push_back(i < static_cast<int>(d->data.size()) ? f(d->data[static_cast<size_t>(i)]) : 0.0);
    }
    fields = {{"time_usec", std::to_string(d->time_usec)}, {"array_id", d->array_id},
              {"name", d->name.substr(0, 10)}, {"data", data}};
  }
  return {{"name", name}, {"fields", fields}};
}

}  // namespace quadhand::link::link_testing
