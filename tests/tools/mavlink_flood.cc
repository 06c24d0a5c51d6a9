// quadhand-mavlink-flood: floods MAVLink 2 endpoints on UDP with hostile
// traffic, for the abuse test of quadhand-online and quadhand-sim --udp
// (docs/reliability.md, scripts/mavlink_flood.sh). Four kinds of frames,
// in turn, packed many to a datagram:
//   garbage   random bytes (with stray magic bytes, so the parser resyncs)
//   foreign   valid unsigned frames from another system (id 42): a
//             position far from the vehicle, a heartbeat
//   forged    frames signed with a wrong key, claiming the peer's identity
//   replayed  frames signed with the right key and the peer's identity and
//             link id, made at the start and sent at least --replay-age s
//             later: the peer has sent newer ones since, so each is a replay
// With --target (repeatable) each endpoint gets --rate frames/s of its own,
// claiming the given identity (the one its real peer uses). Prints what was
// sent per target and kind. Exit 0, or 2 for bad options.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>

#include "quadhand/link/frame.h"
#include "quadhand/link/messages.h"
#include "quadhand/link/udp.h"

namespace {

using namespace quadhand;
using Clock = std::chrono::steady_clock;

constexpr int kFramesPerDatagram = 20;
constexpr int kDatagramsPerKind = 64;  // distinct datagrams made per kind and target
enum Kind { kGarbage, kForeign, kForged, kReplayed, kKinds };
const char* const kKindNames[kKinds] = {"garbage", "foreign", "forged", "replayed"};

struct Target {
  link::UdpEndpoint endpoint;
  uint8_t system = 1, component = 1;  // the identity the real peer of this endpoint uses
  std::vector<std::vector<uint8_t>> datagrams[kKinds];
  unsigned long long frames[kKinds] = {}, datagrams_sent = 0, send_failures = 0;
};

// "udp://HOST:PORT,SYSTEM,COMPONENT"
bool ParseTarget(const std::string& text, Target* target, std::string* why) {
  const size_t first = text.find(','), second = text.find(',', first + 1);
  if (first == std::string::npos || second == std::string::npos) {
    *why = "--target '" + text + "': expected udp://HOST:PORT,SYSTEM,COMPONENT";
    return false;
  }
  auto endpoint = link::ParseUdpUrl(text.substr(0, first));
  if (!endpoint.ok()) {
    *why = "--target '" + text + "': " + endpoint.status().message();
    return false;
  }
  target->endpoint = *endpoint;
  try {
    const int system = std::stoi(text.substr(first + 1, second - first - 1));
    const int component = std::stoi(text.substr(second + 1));
    if (system < 1 || system > 255 || component < 0 || component > 255) throw std::out_of_range("id");
    target->system = static_cast<uint8_t>(system);
    target->component = static_cast<uint8_t>(component);
  } catch (const std::exception&) {
    *why = "--target '" + text + "': SYSTEM must be 1..255 and COMPONENT 0..255";
    return false;
  }
  return true;
}

link::Message SomeMessage(std::mt19937& rng, int i) {
  if (i % 2 == 0) {
    link::Heartbeat h;
    h.type = 2;
    h.base_mode = static_cast<uint8_t>(rng());
    return h;
  }
  link::LocalPositionNed p;  // 100 m away: anyone taking it would fly off at once
  p.x = 100.0f;
  p.y = -100.0f;
  p.z = -50.0f;
  p.time_boot_ms = static_cast<uint32_t>(rng());
  return p;
}

void MakeDatagrams(const link::SigningKey& key, std::mt19937& rng, Target* target) {
  link::SigningKey wrong = key;
  wrong[0] ^= 0x5a;
  link::EncoderOptions foreign{42, 1, std::nullopt, 0};
  link::EncoderOptions forged{target->system, target->component, wrong, 0};
  link::EncoderOptions replayed{target->system, target->component, key, 0};
  link::Encoder encoders[kKinds] = {link::Encoder(), link::Encoder(foreign), link::Encoder(forged),
                                    link::Encoder(replayed)};
  for (int kind = 0; kind < kKinds; ++kind) {
    for (int d = 0; d < kDatagramsPerKind; ++d) {
      std::vector<uint8_t> datagram;
      for (int f = 0; f < kFramesPerDatagram; ++f) {
        if (kind == kGarbage) {
          for (int b = 0; b < 40; ++b) datagram.push_back(b % 13 == 0 ? link::kMagicV2 : static_cast<uint8_t>(rng()));
        } else {
          const std::vector<uint8_t> frame = encoders[kind].Encode(SomeMessage(rng, f));
          datagram.insert(datagram.end(), frame.begin(), frame.end());
        }
      }
      target->datagrams[kind].push_back(std::move(datagram));
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"quadhand-mavlink-flood: hostile MAVLink 2 traffic on UDP for abuse tests (docs/reliability.md)"};
  std::vector<std::string> target_texts;
  std::string key_path;
  double rate = 100000.0, seconds = 10.0, replay_age = 0.5;
  unsigned seed = 1;
  app.add_option("--target", target_texts,
                 "udp://HOST:PORT,SYSTEM,COMPONENT: an endpoint to flood and the identity its real peer uses "
                 "(repeatable)")
      ->required();
  app.add_option("--key", key_path, "The link's signing key (64 hex digits or 32 bytes): replays are signed with it")
      ->required();
  app.add_option("--rate", rate, "Frames per second per target")->capture_default_str();
  app.add_option("--seconds", seconds, "Duration of the flood")->capture_default_str();
  app.add_option("--replay-age", replay_age, "Seconds between making the replayed frames and sending the first")
      ->capture_default_str();
  app.add_option("--seed", seed, "Seed of the random bytes")->capture_default_str();
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);
    std::fprintf(stderr, "quadhand-mavlink-flood: error: %s\n", e.what());
    return 2;
  }
  auto fail = [](const std::string& why) {
    std::fprintf(stderr, "quadhand-mavlink-flood: error: %s\n", why.c_str());
    return 2;
  };
  if (!(rate >= 1.0 && rate <= 1e7)) return fail("--rate must be in [1, 1e7] frames/s");
  if (!(seconds > 0.0 && seconds <= 3600.0)) return fail("--seconds must be in (0, 3600]");
  if (!(replay_age >= 0.0 && replay_age <= 60.0)) return fail("--replay-age must be in [0, 60] s");
  auto key = link::LoadSigningKey(key_path);
  if (!key.ok()) return fail(key.status().message());
  std::vector<Target> targets(target_texts.size());
  std::mt19937 rng(seed);
  for (size_t i = 0; i < targets.size(); ++i) {
    std::string why;
    if (!ParseTarget(target_texts[i], &targets[i], &why)) return fail(why);
    MakeDatagrams(*key, rng, &targets[i]);
  }
  auto socket = link::UdpSocket::Bind({"127.0.0.1", 0});
  if (!socket.ok()) return fail(socket.status().message());
  std::this_thread::sleep_for(std::chrono::duration<double>(replay_age));

  // Datagrams go out on a fixed schedule (rate / frames per datagram per
  // target), the kinds in turn; a late schedule is caught up, not skipped.
  const double interval = kFramesPerDatagram / rate;
  const auto start = Clock::now();
  long sent_rounds = 0;
  for (;;) {
    const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
    if (elapsed >= seconds) break;
    const long due = static_cast<long>(elapsed / interval) + 1;
    if (sent_rounds >= due) {
      std::this_thread::sleep_for(std::chrono::microseconds(200));
      continue;
    }
    for (; sent_rounds < due; ++sent_rounds) {
      const int kind = static_cast<int>(sent_rounds % kKinds);
      for (Target& t : targets) {
        const std::vector<uint8_t>& datagram = t.datagrams[kind][(sent_rounds / kKinds) % kDatagramsPerKind];
        if (socket->SendTo(datagram, t.endpoint).ok()) {
          t.frames[kind] += kFramesPerDatagram;
          ++t.datagrams_sent;
        } else {
          ++t.send_failures;
        }
      }
    }
  }
  const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
  for (const Target& t : targets) {
    unsigned long long total = 0;
    for (int kind = 0; kind < kKinds; ++kind) total += t.frames[kind];
    std::printf("flood %s: %llu frames in %.2f s (%.0f frames/s) in %llu datagrams (%llu send failures):",
                t.endpoint.ToString().c_str(), total, elapsed, total / elapsed, t.datagrams_sent, t.send_failures);
    for (int kind = 0; kind < kKinds; ++kind) std::printf(" %s %llu", kKindNames[kind], t.frames[kind]);
    std::printf("\n");
  }
  return 0;
}
