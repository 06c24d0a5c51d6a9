// UDP transport on the loopback interface, endpoint parsing, and a
// Connection pair exchanging messages.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "quadhand/link/connection.h"
#include "quadhand/link/udp.h"

namespace quadhand::link {
namespace {

UdpSocket BindLoopback() {
  core::Result<UdpSocket> socket = UdpSocket::Bind({"127.0.0.1", 0});
  EXPECT_TRUE(socket.ok()) << socket.status().message();
  return std::move(socket).value();
}

TEST(UdpTest, ParsesGoodUrls) {
  core::Result<UdpEndpoint> e = ParseUdpUrl("udp://127.0.0.1:14540");
  ASSERT_TRUE(e.ok()) << e.status().message();
  EXPECT_EQ(e->host, "127.0.0.1");
  EXPECT_EQ(e->port, 14540);
  EXPECT_EQ(e->ToString(), "udp://127.0.0.1:14540");
  e = ParseUdpUrl("udp://localhost:65535");
  ASSERT_TRUE(e.ok());
  EXPECT_EQ(e->host, "localhost");
  EXPECT_EQ(e->port, 65535);
  e = ParseUdpUrl("udp://0.0.0.0:0", /*allow_port_zero=*/true);
  ASSERT_TRUE(e.ok());
  EXPECT_EQ(e->port, 0);
}

TEST(UdpTest, RejectsBadUrls) {
  for (const std::string url : {"", "127.0.0.1:14540", "tcp://127.0.0.1:14540", "udp://127.0.0.1", "udp://:14540",
                                "udp://127.0.0.1:", "udp://127.0.0.1:0", "udp://127.0.0.1:65536",
                                "udp://127.0.0.1:14x40", "udp://127.0.0.1:-1", "udp://a b:1", "udp://h:123456"}) {
    SCOPED_TRACE(url);
    core::Result<UdpEndpoint> e = ParseUdpUrl(url);
    ASSERT_FALSE(e.ok());
    EXPECT_EQ(e.status().code(), core::StatusCode::kInvalidArgument);
    EXPECT_NE(e.status().message().find("udp://HOST:PORT"), std::string::npos);
  }
}

TEST(UdpTest, LoopbackSendAndReceive) {
  UdpSocket a = BindLoopback();
  UdpSocket b = BindLoopback();
  ASSERT_NE(a.local_port(), 0);
  ASSERT_NE(a.local_port(), b.local_port());
  EXPECT_FALSE(b.Receive().has_value());  // nothing yet, and no blocking
  EXPECT_FALSE(b.WaitReadable(0.01));
  const std::vector<uint8_t> bytes = {1, 2, 3, 0xFD, 0};
  ASSERT_TRUE(a.SendTo(bytes, {"127.0.0.1", b.local_port()}).ok());
  ASSERT_TRUE(a.SendTo({9}, {"localhost", b.local_port()}).ok());
  ASSERT_TRUE(b.WaitReadable(2.0));
  std::optional<Datagram> d = b.Receive();
  ASSERT_TRUE(d.has_value());
  EXPECT_EQ(d->bytes, bytes);
  EXPECT_EQ(d->from.host, "127.0.0.1");
  EXPECT_EQ(d->from.port, a.local_port());
  ASSERT_TRUE(b.WaitReadable(2.0));
  d = b.Receive();
  ASSERT_TRUE(d.has_value());
  EXPECT_EQ(d->bytes, std::vector<uint8_t>{9});
  EXPECT_FALSE(b.Receive().has_value());
}

TEST(UdpTest, BindingATakenPortFails) {
  UdpSocket a = BindLoopback();
  core::Result<UdpSocket> again = UdpSocket::Bind({"127.0.0.1", a.local_port()});
  ASSERT_FALSE(again.ok());
  EXPECT_EQ(again.status().code(), core::StatusCode::kIoError);
}

TEST(UdpTest, MovedSocketKeepsWorking) {
  UdpSocket a = BindLoopback();
  UdpSocket b = BindLoopback();
  const uint16_t port = b.local_port();
  UdpSocket moved = std::move(b);
  ASSERT_TRUE(a.SendTo({7}, {"127.0.0.1", port}).ok());
  ASSERT_TRUE(moved.WaitReadable(2.0));
  EXPECT_TRUE(moved.Receive().has_value());
}

TEST(UdpTest, ConnectionsExchangeMessagesAndLearnTheRemote) {
  UdpSocket vehicle_socket = BindLoopback();
  const uint16_t vehicle_port = vehicle_socket.local_port();
  EncoderOptions vehicle_id;
  vehicle_id.system_id = 1;
  Connection vehicle(std::move(vehicle_socket), vehicle_id, {});
  EncoderOptions gcs_id;
  gcs_id.system_id = 255;
  gcs_id.component_id = 190;
  Connection gcs(BindLoopback(), gcs_id, {}, UdpEndpoint{"127.0.0.1", vehicle_port});

  EXPECT_FALSE(vehicle.Send(Heartbeat{}).ok());  // no remote yet
  CommandLong arm;
  arm.command = mav::kCmdComponentArmDisarm;
  arm.param1 = 1;
  ASSERT_TRUE(gcs.Send(arm).ok());
  ASSERT_TRUE(vehicle.WaitReadable(2.0));
  std::vector<ReceivedMessage> received = vehicle.Poll();
  ASSERT_EQ(received.size(), 1u);
  EXPECT_EQ(received[0].frame.system_id, 255);
  EXPECT_EQ(std::get<CommandLong>(received[0].message).param1, 1.0f);
  ASSERT_TRUE(vehicle.remote().has_value());
  EXPECT_EQ(vehicle.remote()->port, gcs.local_port());

  CommandAck ack;
  ack.command = mav::kCmdComponentArmDisarm;
  ASSERT_TRUE(vehicle.Send(ack).ok());
  ASSERT_TRUE(vehicle.Send(Heartbeat{}).ok());
  std::vector<ReceivedMessage> replies;
  for (int i = 0; i < 100 && replies.size() < 2; ++i) {
    gcs.WaitReadable(0.05);
    for (ReceivedMessage& m : gcs.Poll()) replies.push_back(std::move(m));
  }
  ASSERT_EQ(replies.size(), 2u);
  EXPECT_TRUE(std::holds_alternative<CommandAck>(replies[0].message));
  EXPECT_TRUE(std::holds_alternative<Heartbeat>(replies[1].message));
  EXPECT_EQ(vehicle.frames_sent(), 2u);
  EXPECT_EQ(gcs.stats().frames_accepted, 2u);
}

}  // namespace
}  // namespace quadhand::link
