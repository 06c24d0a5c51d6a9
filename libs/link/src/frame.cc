// MAVLink 2 framing, signing and stream parsing (see frame.h and docs/link.md).
#include "quadhand/link/frame.h"

#include <openssl/evp.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <fstream>
#include <iterator>
#include <sstream>

#include "quadhand/core/file_util.h"

namespace quadhand::link {
namespace {

// Signing timestamps count 10 us units from 2015-01-01 00:00:00 UTC, which is
// 1420070400 s after the Unix epoch.
constexpr uint64_t kMavlinkEpochUnixSeconds = 1420070400ULL;
// A new signing stream is accepted only if its first timestamp is no older
// than this behind the newest timestamp accepted from any stream (the
// MAVLink signing guide's one-minute window), so that a recorded stream of a
// link id never seen before cannot be replayed much later.
constexpr uint64_t kNewStreamWindow = 60ULL * 100000ULL;  // 60 s in 10 us units

uint32_t ReadLe(const uint8_t* p, int n) {
  uint32_t v = 0;
  for (int i = 0; i < n; ++i) v |= static_cast<uint32_t>(p[i]) << (8 * i);
  return v;
}

// First 6 bytes of SHA-256(key + header + payload + crc + link id + timestamp),
// where `frame` holds everything from the magic byte up to the timestamp.
std::array<uint8_t, 6> ComputeSignature(const SigningKey& key, const uint8_t* frame, size_t length) {
  std::array<uint8_t, EVP_MAX_MD_SIZE> digest{};
  unsigned int digest_length = 0;
  EVP_MD_CTX* ctx = EVP_MD_CTX_new();
  // EVP calls only fail on allocation failure; the signature is then all
  // zeros and verification fails, which is the safe outcome.
  if (ctx != nullptr && EVP_DigestInit_ex(ctx, EVP_sha256(), nullptr) == 1 &&
      EVP_DigestUpdate(ctx, key.data(), key.size()) == 1 && EVP_DigestUpdate(ctx, frame, length) == 1) {
    EVP_DigestFinal_ex(ctx, digest.data(), &digest_length);
  }
  EVP_MD_CTX_free(ctx);
  std::array<uint8_t, 6> signature{};
  std::copy_n(digest.begin(), 6, signature.begin());
  return signature;
}

int HexValue(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

}  // namespace

uint16_t Crc16(const uint8_t* data, size_t length, uint16_t crc) {
  // The byte-wise form of CRC-16/MCRF4XX used by MAVLink's reference code
  // (crc_accumulate): no table, a handful of shifts per byte.
  for (size_t i = 0; i < length; ++i) {
    uint8_t tmp = static_cast<uint8_t>(data[i] ^ static_cast<uint8_t>(crc & 0xFF));
    tmp = static_cast<uint8_t>(tmp ^ (tmp << 4));
    crc = static_cast<uint16_t>((crc >> 8) ^ (static_cast<uint16_t>(tmp) << 8) ^
                                (static_cast<uint16_t>(tmp) << 3) ^ (tmp >> 4));
  }
  return crc;
}

core::Result<SigningKey> LoadSigningKey(const std::string& path) {
  // A key file is a few dozen bytes; anything that is not a small regular
  // file is refused before it is opened.
  auto read = core::ReadFileToString(path, 4096);
  if (!read.ok()) return read.status().WithPrefix("signing key");
  const std::string& bytes = *read;
  SigningKey key{};
  // Hex form first: 64 hex digits with any whitespace around or between.
  std::string hex;
  bool all_hex = true;
  for (char c : bytes) {
    if (std::isspace(static_cast<unsigned char>(c))) continue;
    if (HexValue(c) < 0) {
      all_hex = false;
      break;
    }
    hex.push_back(c);
  }
  if (all_hex && hex.size() == 64) {
    for (size_t i = 0; i < 32; ++i) {
      key[i] = static_cast<uint8_t>(HexValue(hex[2 * i]) * 16 + HexValue(hex[2 * i + 1]));
    }
    return key;
  }
  if (bytes.size() == 32) {
    std::copy(bytes.begin(), bytes.end(), key.begin());
    return key;
  }
  std::ostringstream why;
  why << path << ": a signing key must be 64 hexadecimal digits or exactly 32 raw bytes (found "
      << bytes.size() << " bytes";
  if (all_hex) why << ", " << hex.size() << " hex digits";
  why << ")";
  return core::Status::InvalidArgument(why.str());
}

uint64_t SigningTimestampNow() {
  const auto since_unix = std::chrono::system_clock::now().time_since_epoch();
  const int64_t us = std::chrono::duration_cast<std::chrono::microseconds>(since_unix).count();
  const int64_t mavlink_us = us - static_cast<int64_t>(kMavlinkEpochUnixSeconds) * 1000000;
  return mavlink_us > 0 ? static_cast<uint64_t>(mavlink_us) / 10 : 0;
}

Encoder::Encoder(EncoderOptions options) : options_(std::move(options)) {}

std::vector<uint8_t> Encoder::Encode(const Message& message) {
  const uint32_t id = MessageId(message);
  return EncodeRaw(id, FindMessageInfo(id)->crc_extra, SerializePayload(message));
}

std::vector<uint8_t> Encoder::EncodeRaw(uint32_t message_id, uint8_t crc_extra, std::vector<uint8_t> payload) {
  // MAVLink 2 truncation: strip trailing zero bytes but keep the first byte
  // (as the reference C library does); receivers accept length 0 as well.
  size_t length = std::min<size_t>(payload.size(), 255);
  while (length > 1 && payload[length - 1] == 0) --length;
  const bool sign = options_.signing_key.has_value();

  std::vector<uint8_t> frame;
  frame.reserve(kHeaderLength + length + kChecksumLength + (sign ? kSignatureLength : 0));
  frame.push_back(kMagicV2);
  frame.push_back(static_cast<uint8_t>(length));
  frame.push_back(sign ? kIncompatSigned : 0);
  frame.push_back(0);  // compat flags
  frame.push_back(sequence_++);
  frame.push_back(options_.system_id);
  frame.push_back(options_.component_id);
  frame.push_back(static_cast<uint8_t>(message_id & 0xFF));
  frame.push_back(static_cast<uint8_t>((message_id >> 8) & 0xFF));
  frame.push_back(static_cast<uint8_t>((message_id >> 16) & 0xFF));
  frame.insert(frame.end(), payload.begin(), payload.begin() + static_cast<std::ptrdiff_t>(length));
  uint16_t crc = Crc16(frame.data() + 1, frame.size() - 1);
  crc = Crc16(&crc_extra, 1, crc);
  frame.push_back(static_cast<uint8_t>(crc & 0xFF));
  frame.push_back(static_cast<uint8_t>(crc >> 8));
  if (sign) {
    // Strictly increasing timestamps even when several frames are sent within
    // one 10 us tick (the receiver rejects equal timestamps as replays).
    const uint64_t timestamp = std::max(SigningTimestampNow(), last_timestamp_ + 1);
    last_timestamp_ = timestamp;
    frame.push_back(options_.link_id);
    for (int i = 0; i < 6; ++i) frame.push_back(static_cast<uint8_t>((timestamp >> (8 * i)) & 0xFF));
    const std::array<uint8_t, 6> signature = ComputeSignature(*options_.signing_key, frame.data(), frame.size());
    frame.insert(frame.end(), signature.begin(), signature.end());
  }
  return frame;
}

Parser::Parser(ParserOptions options) : options_(std::move(options)) {}

void Parser::Feed(const uint8_t* data, size_t length) { buffer_.insert(buffer_.end(), data, data + length); }

std::optional<Frame> Parser::Next() {
  size_t start = 0;  // bytes of buffer_ already consumed in this call
  // Drops `n` bytes at `start` (garbage or a rejected frame).
  auto skip = [&](size_t n) {
    stats_.bytes_skipped += n;
    start += n;
  };
  auto compact = [&]() { buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(start)); };

  while (true) {
    // Find the next magic byte.
    const auto magic = std::find(buffer_.begin() + static_cast<std::ptrdiff_t>(start), buffer_.end(), kMagicV2);
    skip(static_cast<size_t>(magic - (buffer_.begin() + static_cast<std::ptrdiff_t>(start))));
    const size_t available = buffer_.size() - start;
    if (available < kHeaderLength) break;
    const uint8_t* p = buffer_.data() + start;
    const uint8_t length = p[1];
    const uint8_t incompat = p[2];
    const uint32_t id = ReadLe(p + 7, 3);

    // Rejections that do not need the whole frame skip only the magic byte,
    // so a false magic inside garbage cannot swallow a real frame after it.
    const std::optional<MessageInfo> info = FindMessageInfo(id);
    if (!info) {
      ++stats_.unknown_message;
      skip(1);
      continue;
    }
    if (length > info->max_length) {
      ++stats_.oversized_payload;
      skip(1);
      continue;
    }
    const bool is_signed = (incompat & kIncompatSigned) != 0;
    const size_t total = kHeaderLength + length + kChecksumLength + (is_signed ? kSignatureLength : 0);
    if (available < total) break;  // wait for the rest of the frame

    uint16_t crc = Crc16(p + 1, kHeaderLength - 1 + length);
    crc = Crc16(&info->crc_extra, 1, crc);
    if (crc != static_cast<uint16_t>(ReadLe(p + kHeaderLength + length, 2))) {
      ++stats_.bad_checksum;
      skip(1);
      continue;
    }
    // From here on the frame is genuine: rejected frames are skipped whole.
    if ((incompat & ~kIncompatSigned) != 0) {
      ++stats_.unknown_incompat_flags;
      skip(total);
      continue;
    }

    Frame frame;
    frame.sequence = p[4];
    frame.system_id = p[5];
    frame.component_id = p[6];
    frame.message_id = id;
    frame.payload.assign(p + kHeaderLength, p + kHeaderLength + length);
    frame.is_signed = is_signed;
    if (is_signed) {
      const uint8_t* s = p + kHeaderLength + length + kChecksumLength;
      frame.link_id = s[0];
      frame.timestamp = 0;
      for (int i = 0; i < 6; ++i) frame.timestamp |= static_cast<uint64_t>(s[1 + i]) << (8 * i);
    }

    if (!is_signed && options_.require_signing) {
      ++stats_.unsigned_rejected;
      skip(total);
      continue;
    }
    if (is_signed && (options_.signing_key || options_.require_signing)) {
      // Without a key nothing can be verified: with require_signing every
      // signed frame then counts as badly signed.
      const size_t signed_length = total - 6;
      bool valid = false;
      if (options_.signing_key) {
        const std::array<uint8_t, 6> expected = ComputeSignature(*options_.signing_key, p, signed_length);
        valid = std::equal(expected.begin(), expected.end(), p + signed_length);
      }
      if (!valid) {
        ++stats_.bad_signature;
        skip(total);
        continue;
      }
      // Replay protection per (system, component, link id) stream.
      const uint64_t stream = (static_cast<uint64_t>(frame.system_id) << 16) |
                              (static_cast<uint64_t>(frame.component_id) << 8) | frame.link_id;
      auto it = std::find_if(last_timestamps_.begin(), last_timestamps_.end(),
                             [&](const std::array<uint64_t, 3>& e) { return e[0] == stream; });
      const bool replay = it != last_timestamps_.end()
                              ? frame.timestamp <= (*it)[1]
                              : newest_timestamp_ > kNewStreamWindow &&
                                    frame.timestamp < newest_timestamp_ - kNewStreamWindow;
      if (replay) {
        ++stats_.replayed;
        skip(total);
        continue;
      }
      if (it == last_timestamps_.end()) {
        last_timestamps_.push_back({stream, frame.timestamp, 0});
      } else {
        (*it)[1] = frame.timestamp;
      }
      newest_timestamp_ = std::max(newest_timestamp_, frame.timestamp);
    }

    // Sequence gaps per (system, component): frames lost between two accepted ones.
    const uint32_t source = (static_cast<uint32_t>(frame.system_id) << 8) | frame.component_id;
    auto seq = std::find_if(last_sequences_.begin(), last_sequences_.end(),
                            [&](const std::array<uint32_t, 2>& e) { return e[0] == source; });
    if (seq == last_sequences_.end()) {
      last_sequences_.push_back({source, frame.sequence});
    } else {
      // A repeated sequence number (gap 255) is a duplicate, not 255 losses.
      const uint8_t gap = static_cast<uint8_t>(frame.sequence - (*seq)[1] - 1);
      if (gap != 255) stats_.sequence_gaps += gap;
      (*seq)[1] = frame.sequence;
    }

    ++stats_.frames_accepted;
    start += total;
    compact();
    return frame;
  }
  compact();
  return std::nullopt;
}

}  // namespace quadhand::link
