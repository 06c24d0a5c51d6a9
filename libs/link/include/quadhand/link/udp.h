// UDP transport for the MAVLink link: non-blocking IPv4 sockets and
// "udp://HOST:PORT" endpoints.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "quadhand/core/status.h"

namespace quadhand::link {

struct UdpEndpoint {
  std::string host;  // numeric IPv4 address or a resolvable name
  uint16_t port = 0;
  std::string ToString() const;  // "udp://host:port"
};

// Parses "udp://HOST:PORT" (PORT 0 allowed only where `allow_port_zero`).
core::Result<UdpEndpoint> ParseUdpUrl(const std::string& url, bool allow_port_zero = false);

struct Datagram {
  std::vector<uint8_t> bytes;
  UdpEndpoint from;
};

// A bound, non-blocking UDP socket. Move-only; closes on destruction.
class UdpSocket {
 public:
  // Binds to `local` (port 0: any free port).
  static core::Result<UdpSocket> Bind(const UdpEndpoint& local);
  UdpSocket(UdpSocket&& other) noexcept;
  UdpSocket& operator=(UdpSocket&& other) noexcept;
  UdpSocket(const UdpSocket&) = delete;
  UdpSocket& operator=(const UdpSocket&) = delete;
  ~UdpSocket();

  uint16_t local_port() const { return local_port_; }
  // Asks the kernel for a receive buffer of `bytes` (a burst of large
  // datagrams, such as a sensor frame's chunks, overflows the default);
  // returns what it granted (the system's limit may cap it), 0 on failure.
  size_t SetReceiveBuffer(size_t bytes);
  core::Status SendTo(const std::vector<uint8_t>& bytes, const UdpEndpoint& to);
  // Next waiting datagram, or nullopt when none is waiting (never blocks).
  std::optional<Datagram> Receive();
  // Waits up to `timeout_s` for a datagram to arrive (poll); true when one is waiting.
  bool WaitReadable(double timeout_s);

 private:
  explicit UdpSocket(int fd, uint16_t port) : fd_(fd), local_port_(port) {}
  int fd_ = -1;
  uint16_t local_port_ = 0;
};

}  // namespace quadhand::link
