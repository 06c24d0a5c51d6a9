// The MAVLink v2 stream parser, unsigned and with a signing key (signing
// required): the first byte picks which; the rest is fed in chunks whose
// sizes the following bytes choose, and every accepted frame is taken and
// decoded (what quadhand-online and quadhand-sim do with it). The seeds hold
// a frame of every message the project knows, unsigned and signed with the
// key below.
#include <cstddef>
#include <cstdint>

#include "quadhand/link/frame.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  quadhand::link::ParserOptions options;
  if (data[0] & 1) {
    quadhand::link::SigningKey key{};
    for (size_t i = 0; i < key.size(); ++i) key[i] = static_cast<uint8_t>(i * 7 + 1);
    options.signing_key = key;
    options.require_signing = true;
  }
  quadhand::link::Parser parser(options);
  size_t at = 1;
  while (at < size) {
    const size_t chunk = 1 + data[at] % 64;
    const size_t length = std::min(chunk, size - at);
    parser.Feed(data + at, length);
    at += length;
    while (const auto frame = parser.Next()) {
      const auto message = quadhand::link::Decode(*frame);
      (void)message;
    }
  }
  return 0;
}
