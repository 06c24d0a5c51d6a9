// A MAVLink connection: UdpSocket + Encoder + Parser (see connection.h).
#include "quadhand/link/connection.h"

#include <utility>

namespace quadhand::link {

Connection::Connection(UdpSocket socket, EncoderOptions encoder, ParserOptions parser,
                       std::optional<UdpEndpoint> remote)
    : socket_(std::move(socket)),
      encoder_(std::move(encoder)),
      parser_(std::move(parser)),
      remote_(std::move(remote)) {}

core::Status Connection::Send(const Message& message) {
  if (!remote_) return core::Status::InvalidArgument("no remote known yet: nothing has been received");
  QUADHAND_RETURN_IF_ERROR(socket_.SendTo(encoder_.Encode(message), *remote_));
  ++frames_sent_;
  return core::Status::Ok();
}

std::vector<ReceivedMessage> Connection::Poll(size_t max_datagrams) {
  std::vector<ReceivedMessage> received;
  for (size_t read = 0; read < max_datagrams; ++read) {
    std::optional<Datagram> datagram = socket_.Receive();
    if (!datagram) break;
    // One parser for all datagrams: a datagram normally holds whole frames,
    // and a frame split across datagrams (rare, but legal on a stream
    // transport) is still reassembled.
    parser_.Feed(datagram->bytes);
    while (std::optional<Frame> frame = parser_.Next()) {
      std::optional<Message> message = Decode(*frame);
      if (!message) continue;  // cannot happen: the parser accepts known ids only
      if (!remote_) remote_ = datagram->from;
      received.push_back(ReceivedMessage{std::move(*frame), std::move(*message), datagram->from});
    }
  }
  return received;
}

}  // namespace quadhand::link
