// MAVLink link throughput: encoding and parsing the frames quadhand-online
// and quadhand-sim --udp exchange at 50 Hz, unsigned and signed (SHA-256).
#include <benchmark/benchmark.h>

#include <vector>

#include "quadhand/link/frame.h"
#include "quadhand/link/messages.h"

namespace quadhand::link {
namespace {

Message Setpoint() {
  SetPositionTargetLocalNed sp;
  sp.time_boot_ms = 123456;
  sp.x = 1.25f;
  sp.y = -0.5f;
  sp.z = -1.2f;
  sp.vx = 0.3f;
  sp.vy = 0.1f;
  sp.vz = -0.05f;
  sp.afx = 0.2f;
  sp.afy = -0.1f;
  sp.afz = 0.05f;
  sp.yaw = 1.5f;
  sp.yaw_rate = 0.1f;
  sp.target_system = 1;
  sp.target_component = 1;
  return sp;
}

Message Joints() {
  DebugFloatArray a;
  a.time_usec = 123456789;
  a.array_id = 1;
  a.name = "JOINTS";
  a.data = {0.3f, -0.2f, 0.1f, 0.01f, -0.02f, 0.03f};
  return a;
}

EncoderOptions Options(bool sign) {
  EncoderOptions o;
  if (sign) {
    SigningKey key{};
    for (size_t i = 0; i < key.size(); ++i) key[i] = static_cast<uint8_t>(i);
    o.signing_key = key;
  }
  return o;
}

void BM_Encode(benchmark::State& state) {
  Encoder encoder(Options(state.range(0) != 0));
  const Message m = state.range(1) == 0 ? Setpoint() : Joints();
  size_t bytes = 0;
  for (auto _ : state) {
    std::vector<uint8_t> f = encoder.Encode(m);
    bytes += f.size();
    benchmark::DoNotOptimize(f.data());
  }
  state.SetBytesProcessed(static_cast<int64_t>(bytes));
  state.SetLabel(std::string(state.range(0) ? "signed " : "unsigned ") +
                 (state.range(1) == 0 ? "SET_POSITION_TARGET_LOCAL_NED" : "DEBUG_FLOAT_ARRAY"));
}
BENCHMARK(BM_Encode)->Args({0, 0})->Args({1, 0})->Args({0, 1})->Args({1, 1});

// Parse (and verify) 1000 frames fed as one stream, then decode each.
void BM_ParseDecode(benchmark::State& state) {
  const bool sign = state.range(0) != 0;
  Encoder encoder(Options(sign));
  std::vector<uint8_t> stream;
  for (int i = 0; i < 1000; ++i) {
    const std::vector<uint8_t> f = encoder.Encode(i % 2 ? Setpoint() : Joints());
    stream.insert(stream.end(), f.begin(), f.end());
  }
  ParserOptions po;
  po.signing_key = Options(sign).signing_key;
  for (auto _ : state) {
    // Replay protection would drop the second pass: a fresh parser each time,
    // as after a reconnect.
    Parser parser(po);
    parser.Feed(stream);
    int n = 0;
    while (std::optional<Frame> f = parser.Next()) {
      n += Decode(*f).has_value();
    }
    if (n != 1000) state.SkipWithError("frames lost");
  }
  state.SetItemsProcessed(state.iterations() * 1000);
  state.SetBytesProcessed(state.iterations() * static_cast<int64_t>(stream.size()));
  state.SetLabel(sign ? "signed" : "unsigned");
}
BENCHMARK(BM_ParseDecode)->Arg(0)->Arg(1);

}  // namespace
}  // namespace quadhand::link

BENCHMARK_MAIN();
