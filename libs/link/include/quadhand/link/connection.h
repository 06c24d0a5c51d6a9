// A MAVLink connection over UDP: one socket, an Encoder for what we send and
// a Parser for what we receive. The remote is fixed (a vehicle address) or
// learnt from the first accepted frame (an autopilot answering whoever talks
// to it, as PX4 does on its offboard port).
#pragma once

#include <optional>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/link/frame.h"
#include "quadhand/link/messages.h"
#include "quadhand/link/udp.h"

namespace quadhand::link {

struct ReceivedMessage {
  Frame frame;
  Message message;
  UdpEndpoint from;
};

class Connection {
 public:
  Connection(UdpSocket socket, EncoderOptions encoder, ParserOptions parser,
             std::optional<UdpEndpoint> remote = std::nullopt);

  // Sends to the remote; FailedPrecondition-like InvalidArgument when no remote is known yet.
  core::Status Send(const Message& message);
  // Reads the waiting datagrams, at most `max_datagrams` of them (a flood
  // must not keep the caller from its own work: the rest wait for the next
  // call, or are dropped by the kernel when its buffer is full); returns the
  // decoded messages of accepted frames (unknown ids are counted by the
  // parser and skipped). With no fixed remote, the sender of the first
  // accepted frame becomes the remote.
  std::vector<ReceivedMessage> Poll(size_t max_datagrams = 256);
  // Waits up to timeout_s for input (then call Poll()).
  bool WaitReadable(double timeout_s) { return socket_.WaitReadable(timeout_s); }

  const std::optional<UdpEndpoint>& remote() const { return remote_; }
  const ParserStats& stats() const { return parser_.stats(); }
  uint16_t local_port() const { return socket_.local_port(); }
  uint64_t frames_sent() const { return frames_sent_; }

 private:
  UdpSocket socket_;
  Encoder encoder_;
  Parser parser_;
  std::optional<UdpEndpoint> remote_;
  uint64_t frames_sent_ = 0;
};

}  // namespace quadhand::link
