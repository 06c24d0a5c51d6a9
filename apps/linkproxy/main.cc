// quadhand-linkproxy: a seeded faulty UDP link between quadhand-online (or any
// ground program) and a vehicle (quadhand-sim --udp, PX4). Datagrams from the
// first sender on --listen go to --vehicle through a FaultChannel ("up"),
// and what the vehicle answers goes back through another ("down"): loss,
// bursts, delay, jitter, reordering, duplication, corrupted bytes and
// outages, each direction with its own settings (link/fault_channel.h,
// docs/link.md "Faults on the link").
//
// Exit codes: 0 ran until --duration or SIGINT/SIGTERM; 2 bad input.
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "quadhand/core/log.h"
#include "quadhand/link/fault_channel.h"
#include "quadhand/link/udp.h"

namespace {

using namespace quadhand;
using Clock = std::chrono::steady_clock;

volatile std::sig_atomic_t g_stop = 0;
extern "C" void OnSignal(int) { g_stop = 1; }

int Fail(const std::string& message) {
  core::PrintError("quadhand-linkproxy", message);
  return 2;
}

void PrintStats(const char* direction, const link::FaultChannelStats& s) {
  std::fprintf(stderr,
               "quadhand-linkproxy: %-4s %llu in, %llu delivered; lost %llu (+%llu in outages), %llu duplicated, "
               "%llu corrupted, %llu reordered\n",
               direction, static_cast<unsigned long long>(s.pushed), static_cast<unsigned long long>(s.delivered),
               static_cast<unsigned long long>(s.lost), static_cast<unsigned long long>(s.lost_in_outage),
               static_cast<unsigned long long>(s.duplicated), static_cast<unsigned long long>(s.corrupted),
               static_cast<unsigned long long>(s.reordered));
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "quadhand-linkproxy: a seeded faulty UDP link between a ground program and a vehicle (docs/link.md).\n"
      "  quadhand-linkproxy --listen udp://127.0.0.1:14550 --vehicle udp://127.0.0.1:14540 [--faults FILE]\n"
      "                     [--loss P] [--burst N] [--delay S] [--jitter S] [--fifo] [--duplicate P]\n"
      "                     [--corrupt P] [--outage START,LENGTH]... [--seed N] [--duration S] [--quiet]\n"
      "Point the ground program at --listen (quadhand-online --vehicle udp://127.0.0.1:14550). 'up' is the\n"
      "ground program -> vehicle direction, 'down' the other. The fault options set both directions and\n"
      "override the file's 'both', 'up' and 'down' values; times are s from the proxy's start.\n"
      "Exit codes: 0 ran until --duration or SIGINT/SIGTERM; 2 bad input."};
  std::string listen_url, vehicle_url, faults_path;
  std::optional<double> loss, burst, delay, jitter, duplicate, corrupt;
  std::optional<uint64_t> seed;
  std::vector<std::string> outage_texts;
  bool fifo = false, quiet = false;
  double duration = 0.0;
  app.add_option("--listen", listen_url, "Where the ground program sends, udp://ADDR:PORT")->required();
  app.add_option("--vehicle", vehicle_url, "The vehicle's address, udp://HOST:PORT")->required();
  app.add_option("--faults", faults_path, "Fault configuration (YAML: seed, both, up, down, outages; docs/link.md)");
  app.add_option("--loss", loss, "Long-run fraction of datagrams lost, [0, 1)");
  app.add_option("--burst", burst, "Mean length of a run of lost datagrams (1: independent losses)");
  app.add_option("--delay", delay, "Added one-way delay, s");
  app.add_option("--jitter", jitter, "Delay drawn uniformly in [delay - jitter, delay + jitter], s (reorders)");
  app.add_flag("--fifo", fifo, "Keep the order of datagrams (jitter delays, never reorders)");
  app.add_option("--duplicate", duplicate, "Probability that a datagram arrives twice");
  app.add_option("--corrupt", corrupt, "Probability that one byte of a datagram is changed");
  app.add_option("--outage", outage_texts, "START,LENGTH: nothing passes in either direction for LENGTH s (repeatable)");
  app.add_option("--seed", seed, "Seed of the faults (default: the file's, else 1)");
  app.add_option("--duration", duration, "Stop after this many seconds (0: run until SIGINT/SIGTERM)")
      ->capture_default_str();
  app.add_flag("-q,--quiet", quiet, "Print nothing but errors");
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    return Fail(e.what());
  }
  if (!(std::isfinite(duration) && duration >= 0.0)) return Fail("--duration must be >= 0 s");
  auto listen = link::ParseUdpUrl(listen_url, /*allow_port_zero=*/true);
  if (!listen.ok()) return Fail("--listen " + listen.status().message());
  auto vehicle = link::ParseUdpUrl(vehicle_url);
  if (!vehicle.ok()) return Fail("--vehicle " + vehicle.status().message());

  link::LinkFaultConfig config;
  if (!faults_path.empty()) {
    auto loaded = link::LoadLinkFaultConfig(faults_path);
    if (!loaded.ok()) return Fail(loaded.status().message());
    config = *loaded;
  }
  if (seed) config.seed = *seed;
  std::vector<link::LinkOutage> outages;
  for (const std::string& text : outage_texts) {
    std::istringstream in(text);
    link::LinkOutage o;
    char comma = 0;
    std::string rest;
    if (!(in >> o.start >> comma >> o.length) || comma != ',' || (in >> rest) || !(o.start >= 0.0) ||
        !(o.length > 0.0) || !std::isfinite(o.start) || !std::isfinite(o.length)) {
      return Fail("--outage '" + text + "': expected START,LENGTH in s (START >= 0, LENGTH > 0)");
    }
    outages.push_back(o);
  }
  const std::pair<const char*, const std::optional<double>*> flags[] = {
      {"--loss", &loss}, {"--burst", &burst}, {"--delay", &delay}, {"--jitter", &jitter},
      {"--duplicate", &duplicate}, {"--corrupt", &corrupt}};
  for (link::LinkFaults* faults : {&config.up, &config.down}) {
    if (loss) faults->loss = *loss;
    if (burst) faults->burst = *burst;
    if (delay) faults->delay = *delay;
    if (jitter) faults->jitter = *jitter;
    if (duplicate) faults->duplicate = *duplicate;
    if (corrupt) faults->corrupt = *corrupt;
    if (fifo) faults->fifo = true;
    faults->outages.insert(faults->outages.end(), outages.begin(), outages.end());
    if (std::string why; !faults->IsValid(&why)) {
      for (const auto& [name, value] : flags) {
        if (value->has_value() && why.rfind(std::string(name + 2), 0) == 0) return Fail(std::string(name) + ": " + why);
      }
      return Fail((faults_path.empty() ? std::string("fault options") : faults_path) + ": " + why);
    }
  }

  auto ground_socket = link::UdpSocket::Bind(*listen);
  if (!ground_socket.ok()) return Fail("--listen " + listen_url + ": " + ground_socket.status().message());
  auto vehicle_socket = link::UdpSocket::Bind(link::UdpEndpoint{listen->host, 0});
  if (!vehicle_socket.ok()) return Fail("a socket towards --vehicle: " + vehicle_socket.status().message());
  // A sensor frame's chunks come in a burst of megabytes (docs/link.md,
  // "Sensor frames on UDP"), far beyond the default buffer.
  ground_socket->SetReceiveBuffer(16u << 20);
  vehicle_socket->SetReceiveBuffer(16u << 20);
  // Each direction draws from its own stream, so changing one direction's
  // faults leaves the other's sequence as it was.
  link::FaultChannel up(config.up, config.seed * 2 + 1), down(config.down, config.seed * 2 + 2);

  struct sigaction action {};
  action.sa_handler = OnSignal;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
  if (!quiet) {
    std::fprintf(stderr, "quadhand-linkproxy: %s <-> %s (seed %llu)\n", listen->ToString().c_str(),
                 vehicle->ToString().c_str(), static_cast<unsigned long long>(config.seed));
  }

  const Clock::time_point start = Clock::now();
  auto now = [&start] { return std::chrono::duration<double>(Clock::now() - start).count(); };
  std::optional<link::UdpEndpoint> ground;  // learnt from the first datagram on --listen
  uint64_t send_failures = 0;
  while (!g_stop && (duration <= 0.0 || now() < duration)) {
    // Short waits on each socket in turn: delivery times are kept to about a
    // millisecond, which is finer than any fault worth simulating here.
    ground_socket->WaitReadable(0.0005);
    while (auto d = ground_socket->Receive()) {
      ground = d->from;
      up.Push(now(), std::move(d->bytes));
    }
    vehicle_socket->WaitReadable(0.0005);
    while (auto d = vehicle_socket->Receive()) {
      // Only the vehicle's datagrams go down: anyone else on that port is ignored.
      if (d->from.port == vehicle->port) down.Push(now(), std::move(d->bytes));
    }
    const double t = now();
    for (std::vector<uint8_t>& bytes : up.PopDue(t)) {
      if (!vehicle_socket->SendTo(bytes, *vehicle).ok()) ++send_failures;
    }
    for (std::vector<uint8_t>& bytes : down.PopDue(t)) {
      if (ground && !ground_socket->SendTo(bytes, *ground).ok()) ++send_failures;
    }
  }
  if (!quiet) {
    PrintStats("up", up.stats());
    PrintStats("down", down.stats());
    if (send_failures > 0) {
      std::fprintf(stderr, "quadhand-linkproxy: %llu sends failed\n", static_cast<unsigned long long>(send_failures));
    }
  }
  return 0;
}
