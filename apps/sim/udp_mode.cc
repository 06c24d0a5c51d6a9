#include "udp_mode.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <limits>
#include <optional>
#include <variant>

#include "quadhand/core/file_util.h"
#include "quadhand/core/log.h"
#include "quadhand/link/connection.h"
#include "quadhand/link/sensor_stream.h"
#include "quadhand/perception/sensor_frame.h"
#include "quadhand/robot/kinematics.h"
#include "quadhand/sim/plan_io.h"

namespace quadhand::sim_app {
namespace {

volatile std::sig_atomic_t g_stop = 0;

extern "C" void OnSignal(int) { g_stop = 1; }

void InstallSignalHandlers() {
  struct sigaction action {};
  action.sa_handler = OnSignal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = 0;  // no SA_RESTART: poll() returns early so the loop sees the flag
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}

int Fail(const std::string& message, int code) {
  core::PrintError("quadhand-sim", message);
  return code;
}

using Clock = std::chrono::steady_clock;

double Seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }

}  // namespace

int RunUdpMode(sim::Autopilot autopilot, const UdpModeOptions& options, const std::vector<std::string>& joint_names) {
  core::Result<link::UdpSocket> socket = link::UdpSocket::Bind(options.bind);
  if (!socket.ok()) return Fail("--udp " + options.bind.ToString() + ": " + socket.status().message(), 2);
  link::EncoderOptions encoder;
  encoder.system_id = options.system_id;
  encoder.component_id = 1;  // MAV_COMP_ID_AUTOPILOT1
  encoder.signing_key = options.signing_key;
  link::ParserOptions parser;
  parser.signing_key = options.signing_key;
  parser.require_signing = options.require_signing;
  link::Connection connection(std::move(*socket), encoder, parser, options.remote);
  InstallSignalHandlers();
  if (!options.quiet) {
    std::fprintf(stderr, "quadhand-sim: MAVLink on %s (%s)%s\n", options.bind.ToString().c_str(),
                 options.realtime ? "real time" : "lockstep", options.signing_key ? ", signed" : "");
  }

  uint64_t send_failures = 0;
  std::vector<link::Message> out;
  // Until a peer has spoken (or --remote names one) there is nobody to send to.
  auto flush = [&]() {
    if (connection.remote()) {
      for (const link::Message& m : out) {
        if (!connection.Send(m).ok()) ++send_failures;
      }
    }
    out.clear();
  };
  const double end = options.duration > 0.0 ? options.duration : std::numeric_limits<double>::infinity();

  // The flown record as it grows (core::GrowingFile): every second of
  // simulated time the rows since, so that a killed simulator leaves all but
  // the last second in LOG.partial.
  std::optional<core::GrowingFile> flown_log;
  size_t flown_written = 0;
  double next_log_flush = 1.0;
  auto flush_log = [&]() {
    if (!flown_log) return;
    std::string text =
        flown_written == 0 ? sim::PlanCsvHeader(joint_names, autopilot.records_gripper(), autopilot.records_target()) + "\n" : std::string();
    const std::vector<sim::PlanRow>& rows = autopilot.flown();
    for (; flown_written < rows.size(); ++flown_written) text += sim::PlanCsvRow(rows[flown_written]) + "\n";
    flown_log->Append(text);
  };
  if (!options.log_path.empty()) flown_log.emplace(options.log_path);

  // The sensor's frames, on their own socket (not the MAVLink one).
  std::optional<link::UdpSocket> frame_socket;
  int sensor_link = -1;
  double next_frame = 0.0;
  uint32_t frame_sequence = 0;
  uint64_t frames_sent = 0, frame_send_failures = 0;
  if (options.renderer != nullptr) {
    auto bound = link::UdpSocket::Bind({"0.0.0.0", 0});
    if (!bound.ok()) return Fail("--frames-to: " + bound.status().message(), 2);
    frame_socket.emplace(std::move(*bound));
    sensor_link = options.robot->LinkIndex(options.sensor.link);
  }
  auto send_frame = [&]() {
    const sim::VehicleState& state = autopilot.state();
    const Pose base = MakePose(state.position, state.attitude.toRotationMatrix());
    const Pose pose = robot::LinkPose(*options.robot, base, state.joints, sensor_link) * options.sensor.Mount();
    perception::SensorFrame frame;
    frame.t = autopilot.time();
    perception::SetSensorPose(pose, &frame);
    frame.points = options.renderer->Render(pose);
    frame.misses = options.renderer->LastMisses(options.miss_stride);
    bool sent = true;
    for (const std::vector<uint8_t>& chunk : link::EncodeSensorFrame(frame, frame_sequence++, options.frame_datagram)) {
      if (!frame_socket->SendTo(chunk, options.frames_to).ok()) sent = false;
    }
    ++(sent ? frames_sent : frame_send_failures);
  };
  // Simulates up to t, stopping at each sensor frame's time to render it
  // there (a lockstep or idle step may span several frames).
  auto advance = [&](double t) -> core::Status {
    t = std::min(t, end);
    while (frame_socket && next_frame <= t) {
      QUADHAND_RETURN_IF_ERROR(autopilot.AdvanceTo(next_frame, &out));
      flush();
      send_frame();
      next_frame += 1.0 / options.sensor.rate();
    }
    core::Status s = autopilot.AdvanceTo(t, &out);
    flush();
    return s;
  };

  const Clock::time_point wall_start = Clock::now();
  Clock::time_point last_advance = wall_start;
  double next_status = 0.0;
  core::Status status = advance(0.0);
  while (status.ok() && !g_stop && autopilot.time() < end - 1e-9) {
    connection.WaitReadable(options.realtime ? 0.002 : 0.005);
    for (const link::ReceivedMessage& r : connection.Poll()) {
      autopilot.Handle(r.message, r.frame.system_id, r.frame.component_id, &out);
      flush();  // acknowledgements go out before the vehicle moves on
      if (!options.realtime && std::holds_alternative<link::SetPositionTargetLocalNed>(r.message)) {
        status = advance(autopilot.time() + options.lockstep_period);
        last_advance = Clock::now();
        if (!status.ok()) break;
      }
    }
    if (!status.ok()) break;
    const Clock::time_point now = Clock::now();
    if (options.realtime) {
      status = advance(Seconds(now - wall_start));
    } else if (Seconds(now - last_advance) >= options.lockstep_idle) {
      status = advance(autopilot.time() + Seconds(now - last_advance));
      last_advance = now;
    }
    if (flown_log && autopilot.time() >= next_log_flush) {
      flush_log();
      next_log_flush = std::floor(autopilot.time()) + 1.0;
    }
    if (!options.quiet && autopilot.time() >= next_status) {
      const Vec3& p = autopilot.state().position;
      std::fprintf(stderr, "t %7.2f s  %-8s %-8s  ENU (%7.3f, %7.3f, %7.3f) m  rx %llu tx %llu\n", autopilot.time(),
                   sim::FlightModeName(autopilot.mode()), autopilot.armed() ? "armed" : "disarmed", p.x(), p.y(),
                   p.z(), static_cast<unsigned long long>(connection.stats().frames_accepted),
                   static_cast<unsigned long long>(connection.frames_sent()));
      next_status = std::floor(autopilot.time()) + 1.0;
    }
  }
  // The record ends where the simulation did, diverged or not.
  if (flown_log) {
    flush_log();
    if (core::Status s = flown_log->Finish(); !s.ok()) return Fail(s.message(), 2);
  }
  if (!status.ok()) return Fail(status.message(), 1);
  if (!options.quiet && frame_socket) {
    std::fprintf(stderr, "quadhand-sim: %llu sensor frames sent to %s (%llu could not be sent)\n",
                 static_cast<unsigned long long>(frames_sent), options.frames_to.ToString().c_str(),
                 static_cast<unsigned long long>(frame_send_failures));
  }
  if (!options.quiet) {
    const link::ParserStats& st = connection.stats();
    std::fprintf(stderr,
                 "quadhand-sim: %.2f s simulated in %.2f s; frames received %llu, sent %llu (%llu send failures); "
                 "dropped: %llu bad CRC, %llu unsigned, %llu bad signature, %llu replayed, %llu unknown\n",
                 autopilot.time(), Seconds(Clock::now() - wall_start),
                 static_cast<unsigned long long>(st.frames_accepted),
                 static_cast<unsigned long long>(connection.frames_sent()),
                 static_cast<unsigned long long>(send_failures), static_cast<unsigned long long>(st.bad_checksum),
                 static_cast<unsigned long long>(st.unsigned_rejected),
                 static_cast<unsigned long long>(st.bad_signature), static_cast<unsigned long long>(st.replayed),
                 static_cast<unsigned long long>(st.unknown_message));
  }
  return 0;
}

}  // namespace quadhand::sim_app
