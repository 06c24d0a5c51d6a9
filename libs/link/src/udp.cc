// Non-blocking IPv4 UDP sockets (POSIX) and udp:// endpoint parsing.
#include "quadhand/link/udp.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <utility>

namespace quadhand::link {
namespace {

constexpr const char kScheme[] = "udp://";
constexpr size_t kMaxDatagram = 65536;

// Resolves an IPv4 address: numeric first (no lookup), then getaddrinfo.
// An empty host is the wildcard address.
core::Result<sockaddr_in> Resolve(const UdpEndpoint& endpoint) {
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(endpoint.port);
  if (endpoint.host.empty()) {
    address.sin_addr.s_addr = htonl(INADDR_ANY);
    return address;
  }
  if (inet_pton(AF_INET, endpoint.host.c_str(), &address.sin_addr) == 1) return address;
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_DGRAM;
  addrinfo* found = nullptr;
  const int rc = getaddrinfo(endpoint.host.c_str(), nullptr, &hints, &found);
  if (rc != 0 || found == nullptr) {
    return core::Status::NotFound(endpoint.ToString() + ": cannot resolve host '" + endpoint.host +
                                  "': " + gai_strerror(rc));
  }
  address.sin_addr = reinterpret_cast<const sockaddr_in*>(found->ai_addr)->sin_addr;
  freeaddrinfo(found);
  return address;
}

std::string Errno(const std::string& what) { return what + ": " + std::strerror(errno); }

}  // namespace

std::string UdpEndpoint::ToString() const { return std::string(kScheme) + host + ":" + std::to_string(port); }

core::Result<UdpEndpoint> ParseUdpUrl(const std::string& url, bool allow_port_zero) {
  auto bad = [&](const std::string& why) {
    return core::Status::InvalidArgument("'" + url + "': " + why + " (expected udp://HOST:PORT)");
  };
  if (url.rfind(kScheme, 0) != 0) return bad("missing udp:// scheme");
  const std::string rest = url.substr(sizeof(kScheme) - 1);
  const size_t colon = rest.rfind(':');
  if (colon == std::string::npos) return bad("missing :PORT");
  UdpEndpoint endpoint;
  endpoint.host = rest.substr(0, colon);
  const std::string port = rest.substr(colon + 1);
  if (endpoint.host.empty()) return bad("missing host");
  for (char c : endpoint.host) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' ||
                    c == '-' || c == '_';
    if (!ok) return bad("invalid character in host");
  }
  if (port.empty() || port.size() > 5) return bad("port must be a number from 1 to 65535");
  unsigned long value = 0;
  for (char c : port) {
    if (c < '0' || c > '9') return bad("port must be a number from 1 to 65535");
    value = value * 10 + static_cast<unsigned long>(c - '0');
  }
  if (value > 65535 || (value == 0 && !allow_port_zero)) return bad("port must be a number from 1 to 65535");
  endpoint.port = static_cast<uint16_t>(value);
  return endpoint;
}

core::Result<UdpSocket> UdpSocket::Bind(const UdpEndpoint& local) {
  core::Result<sockaddr_in> address = Resolve(local);
  if (!address.ok()) return address.status();
  const int fd = socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd < 0) return core::Status::IoError(Errno("socket"));
  if (bind(fd, reinterpret_cast<const sockaddr*>(&*address), sizeof(sockaddr_in)) != 0) {
    const core::Status status = core::Status::IoError(Errno("cannot bind " + local.ToString()));
    close(fd);
    return status;
  }
  sockaddr_in bound{};
  socklen_t bound_length = sizeof bound;
  if (getsockname(fd, reinterpret_cast<sockaddr*>(&bound), &bound_length) != 0) {
    const core::Status status = core::Status::IoError(Errno("getsockname"));
    close(fd);
    return status;
  }
  return UdpSocket(fd, ntohs(bound.sin_port));
}

UdpSocket::UdpSocket(UdpSocket&& other) noexcept
    : fd_(std::exchange(other.fd_, -1)), local_port_(other.local_port_) {}

UdpSocket& UdpSocket::operator=(UdpSocket&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) close(fd_);
    fd_ = std::exchange(other.fd_, -1);
    local_port_ = other.local_port_;
  }
  return *this;
}

UdpSocket::~UdpSocket() {
  if (fd_ >= 0) close(fd_);
}

size_t UdpSocket::SetReceiveBuffer(size_t bytes) {
  if (fd_ < 0) return 0;
  const int wanted = static_cast<int>(std::min<size_t>(bytes, 1u << 30));
  // SO_RCVBUFFORCE passes net.core.rmem_max where the process may
  // (CAP_NET_ADMIN); SO_RCVBUF is capped by it.
  if (setsockopt(fd_, SOL_SOCKET, SO_RCVBUFFORCE, &wanted, sizeof wanted) != 0) {
    setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &wanted, sizeof wanted);
  }
  int got = 0;
  socklen_t length = sizeof got;
  if (getsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &got, &length) != 0) return 0;
  return static_cast<size_t>(std::max(got, 0));
}

core::Status UdpSocket::SendTo(const std::vector<uint8_t>& bytes, const UdpEndpoint& to) {
  if (fd_ < 0) return core::Status::Internal("send on a closed socket");
  core::Result<sockaddr_in> address = Resolve(to);
  if (!address.ok()) return address.status();
  const ssize_t sent =
      sendto(fd_, bytes.data(), bytes.size(), 0, reinterpret_cast<const sockaddr*>(&*address), sizeof(sockaddr_in));
  if (sent < 0) return core::Status::IoError(Errno("send to " + to.ToString()));
  if (static_cast<size_t>(sent) != bytes.size()) {
    return core::Status::IoError("send to " + to.ToString() + ": datagram truncated");
  }
  return core::Status::Ok();
}

std::optional<Datagram> UdpSocket::Receive() {
  if (fd_ < 0) return std::nullopt;
  std::vector<uint8_t> buffer(kMaxDatagram);
  while (true) {
    sockaddr_in from{};
    socklen_t from_length = sizeof from;
    const ssize_t n = recvfrom(fd_, buffer.data(), buffer.size(), MSG_DONTWAIT,
                               reinterpret_cast<sockaddr*>(&from), &from_length);
    if (n < 0) {
      // EINTR: retry. ECONNREFUSED and friends report an earlier send's ICMP
      // error; they are not datagrams, so read on. Anything else (EAGAIN
      // included) means nothing is waiting.
      if (errno == EINTR || errno == ECONNREFUSED || errno == EHOSTUNREACH || errno == ENETUNREACH) continue;
      return std::nullopt;
    }
    char host[INET_ADDRSTRLEN] = {};
    inet_ntop(AF_INET, &from.sin_addr, host, sizeof host);
    buffer.resize(static_cast<size_t>(n));
    return Datagram{std::move(buffer), UdpEndpoint{host, ntohs(from.sin_port)}};
  }
}

bool UdpSocket::WaitReadable(double timeout_s) {
  if (fd_ < 0) return false;
  pollfd p{};
  p.fd = fd_;
  p.events = POLLIN;
  const int timeout_ms = timeout_s <= 0 ? 0 : static_cast<int>(std::ceil(std::min(timeout_s, 3600.0) * 1000.0));
  const int rc = poll(&p, 1, timeout_ms);
  return rc > 0 && (p.revents & POLLIN) != 0;
}

}  // namespace quadhand::link
