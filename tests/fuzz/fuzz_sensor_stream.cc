// The sensor-frame receiver (link/sensor_stream.h), as quadhand-map
// --listen uses it: the input is cut into datagrams, each preceded by two
// bytes (little-endian) that choose its length, and each is fed to the
// assembler; a completed frame goes through the frame gate and, when taken,
// its returns are moved into the world. The seeds hold valid chunks: a
// one-chunk frame and a three-chunk frame.
#include <algorithm>
#include <cstddef>
#include <cstdint>

#include "quadhand/link/sensor_stream.h"
#include "quadhand/perception/sensor_frame.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace quadhand;
  link::SensorFrameAssembler assembler(2, size_t{1} << 16);
  perception::FrameGate gate;
  size_t at = 0;
  while (at + 2 <= size) {
    const size_t wanted = static_cast<size_t>(data[at]) | (static_cast<size_t>(data[at + 1]) << 8);
    at += 2;
    const size_t length = std::min(wanted, size - at);
    if (auto frame = assembler.Add(data + at, length)) {
      if (gate.Admit(*frame, frame->t) == perception::FrameDrop::kNone) {
        const Pose pose = perception::SensorPose(*frame);
        Vec3 sum = Vec3::Zero();
        for (const Vec3& p : frame->points) sum += pose * p;
        for (const Vec3& p : frame->misses) sum += pose * p;
        (void)sum;
      }
    }
    at += length;
  }
  assembler.Flush();
  return 0;
}
