// Interoperability with an independent implementation: node-mavlink (npm,
// pinned in tests/link/peer/package-lock.json, installed by scripts/setup.sh)
// decodes every message we send, signed and unsigned, and we decode every
// message it sends. Node and the peer's node_modules are required: a missing
// one fails the test (setup.sh installs both), it is never skipped.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "link/sample_messages.h"
#include "quadhand/link/frame.h"
#include "quadhand/link/messages.h"

namespace quadhand::link {
namespace {

using link_testing::SampleMessages;
using link_testing::ToJson;
using nlohmann::json;

const std::string kPeerDir = std::string(QUADHAND_SOURCE_DIR) + "/tests/link/peer";

SigningKey KeyOf(uint8_t first) {
  SigningKey key;
  for (size_t i = 0; i < key.size(); ++i) key[i] = static_cast<uint8_t>(first + 7 * i);
  return key;
}

std::string Hex(const std::vector<uint8_t>& bytes) {
  static const char* digits = "0123456789abcdef";
  std::string s;
  for (uint8_t b : bytes) {
    s.push_back(digits[b >> 4]);
    s.push_back(digits[b & 15]);
  }
  return s;
}

std::string Hex(const SigningKey& key) { return Hex(std::vector<uint8_t>(key.begin(), key.end())); }

std::vector<uint8_t> FromHex(const std::string& hex) {
  std::vector<uint8_t> bytes;
  for (size_t i = 0; i + 1 < hex.size(); i += 2) {
    bytes.push_back(static_cast<uint8_t>(std::stoi(hex.substr(i, 2), nullptr, 16)));
  }
  return bytes;
}

std::string ReadFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Runs `node peer.js <args>` with `input` on stdin; returns stdout, or fails.
std::string RunPeer(const std::string& args, const std::string& input) {
  const std::string node = QUADHAND_NODE_EXECUTABLE;
  EXPECT_FALSE(node.empty()) << "node was not found when CMake configured the tests: run scripts/setup.sh";
  std::ifstream module(kPeerDir + "/node_modules/node-mavlink/package.json");
  EXPECT_TRUE(module.good()) << kPeerDir << "/node_modules is missing: run scripts/setup.sh (npm ci there)";
  if (node.empty() || !module.good()) return "";
  const std::string base = ::testing::TempDir() + "/link_peer_" + std::to_string(getpid()) + "_" +
                           ::testing::UnitTest::GetInstance()->current_test_info()->name();
  {
    std::ofstream in(base + ".in");
    in << input;
  }
  const std::string command = "cd '" + kPeerDir + "' && '" + node + "' peer.js " + args + " < '" + base +
                              ".in' > '" + base + ".out' 2> '" + base + ".err'";
  const int rc = std::system(command.c_str());
  const std::string out = ReadFile(base + ".out");
  EXPECT_EQ(rc, 0) << "peer.js " << args << " failed: " << ReadFile(base + ".err");
  std::remove((base + ".in").c_str());
  std::remove((base + ".out").c_str());
  std::remove((base + ".err").c_str());
  return out;
}

std::vector<json> JsonLines(const std::string& text) {
  std::vector<json> lines;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    if (!line.empty()) lines.push_back(json::parse(line));
  }
  return lines;
}

// node-mavlink decodes what we send, field by field, and checks signatures.
void ExpectPeerDecodes(bool sign) {
  EncoderOptions options;
  options.system_id = 17;
  options.component_id = 191;
  options.link_id = 9;
  if (sign) options.signing_key = KeyOf(3);
  Encoder encoder(options);
  const std::vector<Message> messages = SampleMessages();
  std::string input;
  for (const Message& m : messages) input += Hex(encoder.Encode(m)) + "\n";
  // An all-zero message (one payload byte kept) and a frame signed with
  // another key, which the peer must see as badly signed.
  input += Hex(encoder.Encode(CommandAck{})) + "\n";
  std::vector<uint8_t> wrong;
  if (sign) {
    EncoderOptions other = options;
    other.signing_key = KeyOf(4);
    Encoder wrong_encoder(other);
    wrong = wrong_encoder.Encode(Heartbeat{});
    input += Hex(wrong) + "\n";
  }
  const std::vector<json> lines = JsonLines(RunPeer("decode --key " + Hex(KeyOf(3)), input));
  const size_t expected = messages.size() + 1 + (sign ? 1 : 0);
  ASSERT_EQ(lines.size(), expected + 1) << "one line per frame and a summary";
  EXPECT_EQ(lines.back()["summary"]["valid"], expected);
  EXPECT_EQ(lines.back()["summary"]["invalid"], 0);
  EXPECT_EQ(lines.back()["summary"]["unknown"], 0);
  std::vector<Message> all = messages;
  all.push_back(CommandAck{});
  for (size_t i = 0; i < all.size(); ++i) {
    const json& got = lines[i];
    const json want = ToJson(all[i]);
    SCOPED_TRACE(want["name"].get<std::string>());
    EXPECT_EQ(got["name"], want["name"]);
    EXPECT_EQ(got["sysid"], 17);
    EXPECT_EQ(got["compid"], 191);
    EXPECT_EQ(got["seq"], i);
    EXPECT_EQ(got["signed"], sign);
    if (sign) {
      EXPECT_EQ(got["signatureValid"], true);
      EXPECT_EQ(got["linkId"], 9);
    }
    for (const auto& [field, value] : want["fields"].items()) {
      EXPECT_EQ(got["fields"][field], value) << field;
    }
    EXPECT_EQ(got["fields"].size(), want["fields"].size());
  }
  if (sign) {
    EXPECT_EQ(lines[all.size()]["signatureValid"], false);
  }
}

TEST(PeerTest, NodeMavlinkDecodesEveryMessageWeSendUnsigned) { ExpectPeerDecodes(false); }
TEST(PeerTest, NodeMavlinkDecodesEveryMessageWeSendSigned) { ExpectPeerDecodes(true); }

// We decode what node-mavlink sends, including its 0-byte all-zero payload.
void ExpectWeDecode(bool sign) {
  const std::vector<Message> messages = SampleMessages();
  json specs = json::array();
  for (const Message& m : messages) specs.push_back(ToJson(m));
  specs.push_back({{"name", "HEARTBEAT"}, {"fields", json::object()}});  // all zero
  std::string args = "encode --sysid 42 --compid 7";
  if (sign) args += " --key " + Hex(KeyOf(5)) + " --link-id 6";
  const std::string out = RunPeer(args, specs.dump());
  ParserOptions options;
  if (sign) {
    options.signing_key = KeyOf(5);
    options.require_signing = true;
  }
  Parser parser(options);
  std::istringstream lines(out);
  std::string line;
  std::vector<Frame> frames;
  while (std::getline(lines, line)) {
    parser.Feed(FromHex(line));
    while (std::optional<Frame> f = parser.Next()) frames.push_back(std::move(*f));
  }
  ASSERT_EQ(frames.size(), specs.size()) << out;
  EXPECT_EQ(parser.stats().bytes_skipped, 0u);
  for (size_t i = 0; i < frames.size(); ++i) {
    SCOPED_TRACE(specs[i]["name"].get<std::string>());
    EXPECT_EQ(frames[i].system_id, 42);
    EXPECT_EQ(frames[i].component_id, 7);
    EXPECT_EQ(frames[i].is_signed, sign);
    if (sign) {
      EXPECT_EQ(frames[i].link_id, 6);
    }
    const std::optional<Message> decoded = Decode(frames[i]);
    ASSERT_TRUE(decoded);
    if (i < messages.size()) {
      EXPECT_EQ(ToJson(*decoded), specs[i]);
    } else {
      EXPECT_TRUE(frames[i].payload.empty());  // node-mavlink strips every zero byte
      const auto& heartbeat = std::get<Heartbeat>(*decoded);
      EXPECT_EQ(heartbeat.custom_mode, 0u);
      EXPECT_EQ(heartbeat.mavlink_version, 0);
    }
  }
}

TEST(PeerTest, WeDecodeEveryMessageNodeMavlinkSendsUnsigned) { ExpectWeDecode(false); }
TEST(PeerTest, WeDecodeEveryMessageNodeMavlinkSendsSigned) { ExpectWeDecode(true); }

}  // namespace
}  // namespace quadhand::link
