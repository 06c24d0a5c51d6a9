#include "quadhand/scene/ros_bag.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <unistd.h>

#include <bzlib.h>
#include <console_bridge/console.h>
#include <roslz4/lz4s.h>
#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2/buffer_core.h>
#include <tf2/exceptions.h>
#include <tf2_msgs/TFMessage.h>

#include "quadhand/core/text.h"

namespace quadhand::scene {
namespace {

constexpr char kCloudType[] = "sensor_msgs/PointCloud2";
constexpr char kOdomType[] = "nav_msgs/Odometry";
constexpr char kTfType[] = "tf2_msgs/TFMessage";

// rosbag and tf2 report through console_bridge: their warnings would
// interleave with the one line a bad input gets; what they warn of is
// counted instead.
void QuietConsoleBridge() { console_bridge::setLogLevel(console_bridge::CONSOLE_BRIDGE_LOG_NONE); }

bool Fail(std::string* why, const std::string& message) {
  if (why != nullptr) *why = message;
  return false;
}

std::string StripSlash(const std::string& frame) { return !frame.empty() && frame[0] == '/' ? frame.substr(1) : frame; }

// A message's stamp: its header's, or its bag time when that is zero.
ros::Time StampOf(const ros::Time& stamp, const ros::Time& bag_time) { return stamp.isZero() ? bag_time : stamp; }

// A rigid pose from a position and a quaternion [w, x, y, z], or false when
// it is not one (non-finite, or a quaternion off unit length by more than
// 1e-3).
bool ToPose(const Vec3& position, const Eigen::Vector4d& wxyz, Pose* pose) {
  if (!position.allFinite() || !wxyz.allFinite() || std::abs(wxyz.norm() - 1.0) > 1e-3) return false;
  *pose = MakePose(position, Quat(wxyz[0], wxyz[1], wxyz[2], wxyz[3]).normalized().toRotationMatrix());
  return true;
}

geometry_msgs::TransformStamped TransformOf(const Pose& pose, const ros::Time& stamp, const std::string& parent,
                                            const std::string& child) {
  geometry_msgs::TransformStamped out;
  out.header.stamp = stamp;
  out.header.frame_id = parent;
  out.child_frame_id = child;
  const Quat q(pose.linear());
  out.transform.translation.x = pose.translation().x();
  out.transform.translation.y = pose.translation().y();
  out.transform.translation.z = pose.translation().z();
  out.transform.rotation.w = q.w();
  out.transform.rotation.x = q.x();
  out.transform.rotation.y = q.y();
  out.transform.rotation.z = q.z();
  return out;
}

// A message's serialised bytes (ROS 1 serialisation: little-endian,
// strings and arrays as a uint32 length and their elements), read with
// every length checked against the bytes left before anything is sized by
// it. roscpp's own deserialisers size a string or a vector from the length
// they read before they know it is there: a cloud declaring 3 GB of data
// in a 100-byte message made them allocate 3 GB (fuzz_ros_bag).
class MessageReader {
 public:
  explicit MessageReader(const std::vector<uint8_t>& bytes) : at_(bytes.data()), left_(bytes.size()) {}
  bool Skip(size_t n) {
    if (n > left_) return false;
    at_ += n;
    left_ -= n;
    return true;
  }
  template <typename T>
  bool Read(T* value) {
    if (sizeof(T) > left_) return false;
    std::memcpy(value, at_, sizeof(T));
    return Skip(sizeof(T));
  }
  // A uint32 length, then that many bytes: where they are, not a copy.
  bool Span(const uint8_t** data, uint32_t* size) {
    if (!Read(size) || *size > left_) return false;
    *data = at_;
    return Skip(*size);
  }
  bool String(std::string* text) {
    const uint8_t* data = nullptr;
    uint32_t size = 0;
    if (!Span(&data, &size)) return false;
    text->assign(reinterpret_cast<const char*>(data), size);
    return true;
  }
  // std_msgs/Header: seq, stamp, frame_id.
  bool Header(ros::Time* stamp, std::string* frame) {
    uint32_t seq = 0;
    return Read(&seq) && Read(&stamp->sec) && Read(&stamp->nsec) && String(frame);
  }
  // geometry_msgs/Point or Vector3, then Quaternion (x, y, z, w).
  bool Pose7(double xyz[3], double xyzw[4]) {
    for (int k = 0; k < 3; ++k) {
      if (!Read(&xyz[k])) return false;
    }
    for (int k = 0; k < 4; ++k) {
      if (!Read(&xyzw[k])) return false;
    }
    return true;
  }

 private:
  const uint8_t* at_;
  size_t left_;
};

// The serialised bytes of a message, as the bag holds them.
bool MessageBytes(const rosbag::MessageInstance& message, std::vector<uint8_t>* bytes) {
  try {
    bytes->resize(message.size());
    ros::serialization::OStream stream(bytes->data(), static_cast<uint32_t>(bytes->size()));
    message.write(stream);
    return true;
  } catch (const std::exception&) {
    return false;
  }
}

struct CloudField {
  std::string name;
  uint32_t offset = 0, count = 0;
  uint8_t datatype = 0;
};

struct CloudMessage {
  ros::Time stamp;
  std::string frame;
  uint32_t height = 0, width = 0, point_step = 0, row_step = 0;
  std::vector<CloudField> fields;
  uint8_t is_bigendian = 0;
  const uint8_t* data = nullptr;
  uint32_t data_size = 0;
};

// sensor_msgs/PointCloud2, or false when the bytes do not hold one.
bool ReadCloudMessage(const std::vector<uint8_t>& bytes, CloudMessage* cloud) {
  MessageReader r(bytes);
  uint32_t count = 0;
  if (!r.Header(&cloud->stamp, &cloud->frame) || !r.Read(&cloud->height) || !r.Read(&cloud->width) || !r.Read(&count)) {
    return false;
  }
  cloud->fields.clear();
  for (uint32_t k = 0; k < count; ++k) {
    CloudField field;
    if (!r.String(&field.name) || !r.Read(&field.offset) || !r.Read(&field.datatype) || !r.Read(&field.count)) {
      return false;
    }
    cloud->fields.push_back(std::move(field));
  }
  uint8_t is_dense = 0;
  return r.Read(&cloud->is_bigendian) && r.Read(&cloud->point_step) && r.Read(&cloud->row_step) &&
         r.Span(&cloud->data, &cloud->data_size) && r.Read(&is_dense);
}

struct StampedPose {
  ros::Time stamp;
  std::string frame, child;
  double position[3] = {0, 0, 0}, orientation[4] = {0, 0, 0, 0};  // x, y, z, w

  bool ToPose(Pose* pose) const {
    return quadhand::scene::ToPose(Vec3(position[0], position[1], position[2]),
                                   Eigen::Vector4d(orientation[3], orientation[0], orientation[1], orientation[2]), pose);
  }
};

// nav_msgs/Odometry's header, child frame and pose (the rest is not read).
bool ReadOdometryMessage(const std::vector<uint8_t>& bytes, StampedPose* odom) {
  MessageReader r(bytes);
  return r.Header(&odom->stamp, &odom->frame) && r.String(&odom->child) && r.Pose7(odom->position, odom->orientation);
}

// tf2_msgs/TFMessage: its transforms.
bool ReadTfMessage(const std::vector<uint8_t>& bytes, std::vector<StampedPose>* transforms) {
  MessageReader r(bytes);
  uint32_t count = 0;
  if (!r.Read(&count)) return false;
  transforms->clear();
  for (uint32_t k = 0; k < count; ++k) {
    StampedPose t;
    if (!r.Header(&t.stamp, &t.frame) || !r.String(&t.child) || !r.Pose7(t.position, t.orientation)) return false;
    transforms->push_back(std::move(t));
  }
  return true;
}

// The finite x, y, z returns of a cloud, or false when it is malformed.
bool DecodeCloud(const CloudMessage& cloud, std::vector<Vec3>* points, long* non_finite) {
  constexpr uint8_t kFloat32 = 7, kFloat64 = 8;  // sensor_msgs/PointField's datatypes
  if (cloud.is_bigendian) return false;
  int offset[3] = {-1, -1, -1};
  uint8_t type[3] = {0, 0, 0};
  const char* names[3] = {"x", "y", "z"};
  for (const CloudField& field : cloud.fields) {
    for (int axis = 0; axis < 3; ++axis) {
      if (field.name != names[axis]) continue;
      if (field.count > 1) return false;
      if (field.datatype != kFloat32 && field.datatype != kFloat64) return false;
      if (field.offset > (1u << 20)) return false;
      offset[axis] = static_cast<int>(field.offset);
      type[axis] = field.datatype;
    }
  }
  const uint64_t width = cloud.width, height = cloud.height, step = cloud.point_step, row = cloud.row_step;
  for (int axis = 0; axis < 3; ++axis) {
    const uint64_t size = type[axis] == kFloat64 ? 8 : 4;
    if (offset[axis] < 0 || static_cast<uint64_t>(offset[axis]) + size > step) return false;
  }
  if (step == 0 || width * step > row || height * row > cloud.data_size) return false;
  points->clear();
  points->reserve(width * height);
  for (uint64_t r = 0; r < height; ++r) {
    for (uint64_t c = 0; c < width; ++c) {
      const uint8_t* at = cloud.data + r * row + c * step;
      double value[3];
      for (int axis = 0; axis < 3; ++axis) {
        if (type[axis] == kFloat64) {
          std::memcpy(&value[axis], at + offset[axis], 8);
        } else {
          float f;
          std::memcpy(&f, at + offset[axis], 4);
          value[axis] = f;
        }
      }
      const Vec3 p(value[0], value[1], value[2]);
      if (p.allFinite()) {
        points->push_back(p);
      } else {
        ++*non_finite;
      }
    }
  }
  return true;
}

// Odometry poses in stamp order, interpolated between neighbours.
class OdometryTrack {
 public:
  void Add(double t, const Pose& pose) { samples_.push_back({t, pose}); }
  void Sort() {
    std::stable_sort(samples_.begin(), samples_.end(), [](const auto& a, const auto& b) { return a.t < b.t; });
  }
  bool At(double t, double max_gap, Pose* pose) const {
    if (samples_.empty() || t < samples_.front().t || t > samples_.back().t) return false;
    auto after = std::lower_bound(samples_.begin(), samples_.end(), t, [](const auto& s, double v) { return s.t < v; });
    if (after->t == t) {
      *pose = after->pose;
      return true;
    }
    const auto before = after - 1;
    const double span = after->t - before->t;
    if (!(span <= max_gap)) return false;
    const double u = (t - before->t) / span;
    const Quat q0(before->pose.linear()), q1(after->pose.linear());
    *pose = MakePose((1.0 - u) * before->pose.translation() + u * after->pose.translation(),
                     q0.slerp(u, q1).toRotationMatrix());
    return true;
  }

 private:
  struct Sample {
    double t;
    Pose pose;
  };
  std::vector<Sample> samples_;
};

std::map<std::string, std::string> TopicTypes(rosbag::Bag& bag) {
  std::map<std::string, std::string> topics;
  rosbag::View all(bag);
  for (const rosbag::ConnectionInfo* connection : all.getConnections()) {
    topics[connection->topic] = connection->datatype;
  }
  return topics;
}

// "/topic [pkg/Type]" for each topic, in name order.
std::vector<std::string> TopicLines(const std::map<std::string, std::string>& topics) {
  std::vector<std::string> lines;
  for (const auto& [topic, type] : topics) lines.push_back(topic + " [" + type + "]");
  return lines;
}

std::string ListTopics(const std::map<std::string, std::string>& topics) {
  if (topics.empty()) return "the bag has no topic";
  std::string list;
  for (const std::string& line : TopicLines(topics)) list += (list.empty() ? "" : ", ") + line;
  return "the bag has " + list;
}

core::Status CheckTopic(const std::string& path, const std::map<std::string, std::string>& topics,
                        const std::string& topic, const char* type) {
  const auto found = topics.find(topic);
  if (found == topics.end()) {
    return core::Status::InvalidArgument(path + ": no topic " + topic + " (" + ListTopics(topics) + ")");
  }
  if (found->second != type) {
    return core::Status::InvalidArgument(path + ": topic " + topic + " is " + found->second + ", not " + type);
  }
  return core::Status::Ok();
}

// rosbag trusts a bag's lengths and offsets: a 200-byte file declaring a
// 4 GB header makes it allocate 4 GB, and an index entry pointing into the
// middle of a chunk makes it read outside its buffer (a SEGV; both found by
// fuzz_ros_bag). So the bag's structure is checked first, as rosbag will
// read it: every record's lengths inside what holds it (the file, its
// header, its chunk, decompressed as rosbag will decompress it); the bag
// header's index position, each chunk info's chunk position and each index
// entry's offset on the start of a record of the right kind.
constexpr uint64_t kMaxRecordHeaderBytes = 64u << 20;  // a connection's message definition is a few kB
constexpr uint64_t kMaxChunkBytes = 1u << 30;
constexpr char kOpMessage = 0x02, kOpBagHeader = 0x03, kOpIndex = 0x04, kOpChunk = 0x05, kOpChunkInfo = 0x06,
               kOpConnection = 0x07;

struct Record {
  uint64_t start = 0;  // where its header length is
  char op = 0;
  std::map<std::string, std::string> fields;
  uint64_t data_at = 0, data_len = 0;
};

template <typename T>
bool FieldValue(const Record& record, const std::string& name, T* value) {
  const auto found = record.fields.find(name);
  if (found == record.fields.end() || found->second.size() != sizeof(T)) return false;
  std::memcpy(value, found->second.data(), sizeof(T));
  return true;
}

// A record header's fields (each a 4-byte length, then name=value), or why not.
std::string ParseFields(const std::string& header, std::map<std::string, std::string>* fields) {
  for (size_t f = 0; f < header.size();) {
    uint32_t field_len = 0;
    if (header.size() - f < 4) return "header field's length runs past its header";
    std::memcpy(&field_len, header.data() + f, 4);
    f += 4;
    if (field_len > header.size() - f) return "header field runs past its header";
    const std::string field = header.substr(f, field_len);
    const size_t equals = field.find('=');
    if (equals == std::string::npos) return "header field without '='";
    (*fields)[field.substr(0, equals)] = field.substr(equals + 1);
    f += field_len;
  }
  return "";
}

// `read(at, n, out)` gives the n bytes at `at`, or false.
using FileReader = std::function<bool(uint64_t, uint64_t, std::string*)>;

// The records from `at` to `end` (of a file, or a chunk), or why not.
std::string ReadRecords(const FileReader& read, uint64_t at, uint64_t end, std::vector<Record>* records) {
  std::string bytes;
  while (at < end) {
    Record record;
    record.start = at;
    uint32_t header_len = 0, data_len = 0;
    if (end - at < 4 || !read(at, 4, &bytes)) return "a record's length runs past the end";
    std::memcpy(&header_len, bytes.data(), 4);
    at += 4;
    if (header_len > end - at || header_len > kMaxRecordHeaderBytes) return "a record's header runs past the end";
    std::string header;
    if (!read(at, header_len, &header)) return "unreadable";
    at += header_len;
    if (std::string why = ParseFields(header, &record.fields); !why.empty()) return "a " + why;
    if (!FieldValue(record, "op", &record.op)) return "a record without its op";
    if (end - at < 4 || !read(at, 4, &bytes)) return "a record's data length runs past the end";
    std::memcpy(&data_len, bytes.data(), 4);
    at += 4;
    if (data_len > end - at) return "a record's data runs past the end";
    if (record.op == kOpConnection) {  // its data is a header too: the connection's
      if (data_len > kMaxRecordHeaderBytes) return "a connection's header is too long";
      std::string connection;
      std::map<std::string, std::string> fields;
      if (!read(at, data_len, &connection)) return "unreadable";
      if (std::string why = ParseFields(connection, &fields); !why.empty()) return "a connection's " + why;
    }
    record.data_at = at;
    record.data_len = data_len;
    at += data_len;
    records->push_back(std::move(record));
  }
  return "";
}

// A chunk's records as rosbag will see them, or why not; their starts are
// offsets in the chunk's (decompressed) data. `read` reads the file. An
// uncompressed chunk is walked in place, its messages' data skipped; a
// compressed one is read and decompressed.
std::string ReadChunk(const Record& chunk, const FileReader& read, std::vector<Record>* records) {
  uint32_t size = 0;
  const auto found = chunk.fields.find("compression");
  if (found == chunk.fields.end() || !FieldValue(chunk, "size", &size)) return "a chunk without its compression or size";
  if (size > kMaxChunkBytes) return "a chunk declares more than 1 GiB";
  if (found->second == "none") {
    if (size != chunk.data_len) return "an uncompressed chunk's size disagrees with its data";
    const std::string why = ReadRecords(read, chunk.data_at, chunk.data_at + chunk.data_len, records);
    for (Record& record : *records) record.start -= chunk.data_at;
    return why;
  }
  if (found->second != "bz2" && found->second != "lz4") return "a chunk compressed as '" + found->second + "'";
  std::string data, plain(size, '\0');
  if (!read(chunk.data_at, chunk.data_len, &data)) return "unreadable";
  unsigned int out = size;
  const int code = found->second == "bz2"
                       ? BZ2_bzBuffToBuffDecompress(plain.data(), &out, data.data(),
                                                    static_cast<unsigned int>(data.size()), 0, 0)
                       : roslz4_buffToBuffDecompress(data.data(), static_cast<unsigned int>(data.size()), plain.data(),
                                                     &out);
  if (code != 0 || out != size) return "a " + found->second + " chunk that does not decompress to its size";
  auto read_plain = [&plain](uint64_t at, uint64_t n, std::string* bytes) {
    if (at > plain.size() || n > plain.size() - at) return false;
    bytes->assign(plain, at, n);
    return true;
  };
  return ReadRecords(read_plain, 0, plain.size(), records);
}

core::Status CheckBagLayout(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  if (!file) return core::Status::InvalidArgument(path + ": cannot open");
  static const std::string kMagic = "#ROSBAG V2.0\n";
  std::string magic(kMagic.size(), '\0');
  file.read(magic.data(), static_cast<std::streamsize>(magic.size()));
  if (static_cast<size_t>(file.gcount()) != magic.size() || magic != kMagic) {
    return core::Status::InvalidArgument(path + ": not a readable ROS 1 bag (no '#ROSBAG V2.0' line at its start)");
  }
  std::error_code ec;
  const uint64_t size = std::filesystem::file_size(path, ec);
  if (ec) return core::Status::InvalidArgument(path + ": " + ec.message());
  auto read = [&file](uint64_t at, uint64_t n, std::string* out) {
    out->resize(n);
    file.clear();
    file.seekg(static_cast<std::streamoff>(at));
    file.read(out->data(), static_cast<std::streamsize>(n));
    return static_cast<uint64_t>(file.gcount()) == n;
  };
  auto bad = [&path](const std::string& why) {
    return core::Status::InvalidArgument(path + ": not a readable ROS 1 bag (" + why + ")");
  };
  std::vector<Record> records;
  if (std::string why = ReadRecords(read, kMagic.size(), size, &records); !why.empty()) return bad(why);
  std::set<uint64_t> starts, chunk_starts;
  for (const Record& record : records) {
    starts.insert(record.start);
    if (record.op == kOpChunk) chunk_starts.insert(record.start);
  }
  std::set<uint64_t> messages;  // offsets of the message records of the chunk before
  bool after_chunk = false;
  for (const Record& record : records) {
    if (record.op == kOpBagHeader) {
      uint64_t index_pos = 0;
      if (!FieldValue(record, "index_pos", &index_pos)) return bad("a bag header without its index position");
      if (index_pos != 0 && index_pos != size && starts.count(index_pos) == 0) {
        return bad("the index position is not a record's start");
      }
    } else if (record.op == kOpChunk) {
      std::vector<Record> inner;
      if (std::string why = ReadChunk(record, read, &inner); !why.empty()) return bad("in a chunk: " + why);
      messages.clear();
      for (const Record& r : inner) {
        if (r.op == kOpMessage) messages.insert(r.start);
      }
      after_chunk = true;
    } else if (record.op == kOpIndex) {
      uint32_t count = 0, version = 0;
      if (!FieldValue(record, "count", &count) || !FieldValue(record, "ver", &version) || version != 1 ||
          record.data_len != 12ull * count) {
        return bad("an index record's count disagrees with its data");
      }
      if (!after_chunk) return bad("an index record before any chunk");
      std::string data;
      if (!read(record.data_at, record.data_len, &data)) return bad("unreadable");
      for (uint32_t e = 0; e < count; ++e) {
        uint32_t offset = 0;
        std::memcpy(&offset, data.data() + 12 * e + 8, 4);
        if (messages.count(offset) == 0) return bad("an index entry that is not on a message in its chunk");
      }
    } else if (record.op == kOpChunkInfo) {
      uint64_t chunk_pos = 0;
      if (!FieldValue(record, "chunk_pos", &chunk_pos) || chunk_starts.count(chunk_pos) == 0) {
        return bad("a chunk info that is not on a chunk");
      }
    }
  }
  return core::Status::Ok();
}

core::Status OpenForReading(const std::string& path, rosbag::Bag* bag) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    return core::Status::InvalidArgument(path + ": " + (std::filesystem::exists(path, ec) ? "not a regular file" : "no such file"));
  }
  QUADHAND_RETURN_IF_ERROR(CheckBagLayout(path));
  try {
    bag->open(path, rosbag::bagmode::Read);
  } catch (const std::exception& e) {
    return core::Status::InvalidArgument(path + ": not a readable ROS 1 bag (" + e.what() + ")");
  }
  return core::Status::Ok();
}

}  // namespace

BagCloudCounts& BagCloudCounts::operator+=(const BagCloudCounts& other) {
  messages += other.messages;
  used += other.used;
  malformed += other.malformed;
  no_pose += other.no_pose;
  non_finite_points += other.non_finite_points;
  poses += other.poses;
  bad_poses += other.bad_poses;
  return *this;
}

bool BagCloudSource::IsValid(std::string* why) const {
  if (path.empty()) return Fail(why, "no bag file given");
  if (cloud_topic.empty()) return Fail(why, "no cloud topic given");
  if (odom_topic.empty() && StripSlash(world_frame).empty()) return Fail(why, "no odometry topic and no world frame given");
  if (!(std::isfinite(max_pose_gap) && max_pose_gap > 0.0)) return Fail(why, "max_pose_gap must be > 0 s");
  if (!IsRigidMotion(extrinsic)) return Fail(why, "the extrinsic is not a rigid motion");
  return true;
}

core::Result<std::vector<std::string>> BagTopics(const std::string& path) {
  QuietConsoleBridge();
  rosbag::Bag bag;
  QUADHAND_RETURN_IF_ERROR(OpenForReading(path, &bag));
  try {
    return TopicLines(TopicTypes(bag));
  } catch (const std::exception& e) {
    return core::Status::InvalidArgument(path + ": not a readable ROS 1 bag (" + e.what() + ")");
  }
}

core::Status ForEachBagCloud(const BagCloudSource& source, const std::function<core::Status(BagCloud&)>& visit,
                             BagCloudCounts* counts) {
  QuietConsoleBridge();
  BagCloudCounts local;
  BagCloudCounts& n = counts != nullptr ? *counts : local;
  n = BagCloudCounts{};
  if (std::string why; !source.IsValid(&why)) return core::Status::InvalidArgument(source.path + ": " + why);
  rosbag::Bag bag;
  QUADHAND_RETURN_IF_ERROR(OpenForReading(source.path, &bag));
  try {
    const std::map<std::string, std::string> topics = TopicTypes(bag);
    QUADHAND_RETURN_IF_ERROR(CheckTopic(source.path, topics, source.cloud_topic, kCloudType));
    OdometryTrack odometry;
    std::unique_ptr<tf2::BufferCore> tf;
    std::vector<uint8_t> bytes;
    std::vector<StampedPose> transforms;
    const std::string world = StripSlash(source.world_frame);
    if (!source.odom_topic.empty()) {
      QUADHAND_RETURN_IF_ERROR(CheckTopic(source.path, topics, source.odom_topic, kOdomType));
      rosbag::View view(bag, rosbag::TopicQuery(source.odom_topic));
      for (const rosbag::MessageInstance& message : view) {
        ++n.poses;
        StampedPose odom;
        Pose pose;
        if (!MessageBytes(message, &bytes) || !ReadOdometryMessage(bytes, &odom) || !odom.ToPose(&pose)) {
          ++n.bad_poses;
          continue;
        }
        odometry.Add(StampOf(odom.stamp, message.getTime()).toSec(), pose);
      }
      odometry.Sort();
    } else {
      std::vector<std::string> tf_topics;
      for (const char* topic : {"/tf", "/tf_static"}) {
        const auto found = topics.find(topic);
        if (found != topics.end() && found->second == kTfType) tf_topics.push_back(topic);
      }
      if (tf_topics.empty()) {
        return core::Status::InvalidArgument(source.path + ": no /tf or /tf_static of " + std::string(kTfType) +
                                             " to place the clouds in frame " + world + " (" + ListTopics(topics) +
                                             "; or give an odometry topic)");
      }
      rosbag::View whole(bag);
      const double span = std::max(0.0, (whole.getEndTime() - whole.getBeginTime()).toSec());
      tf = std::make_unique<tf2::BufferCore>(ros::Duration(span + 10.0));
      rosbag::View view(bag, rosbag::TopicQuery(tf_topics));
      for (const rosbag::MessageInstance& message : view) {
        if (!MessageBytes(message, &bytes) || !ReadTfMessage(bytes, &transforms)) {
          ++n.poses;
          ++n.bad_poses;
          continue;
        }
        const bool is_static = message.getTopic() == "/tf_static";
        for (const StampedPose& transform : transforms) {
          ++n.poses;
          Pose pose;
          if (!transform.ToPose(&pose) ||
              !tf->setTransform(TransformOf(pose, transform.stamp, transform.frame, transform.child), "bag", is_static)) {
            ++n.bad_poses;
          }
        }
      }
    }

    rosbag::View clouds(bag, rosbag::TopicQuery(source.cloud_topic));
    BagCloud cloud;
    CloudMessage msg;
    for (const rosbag::MessageInstance& message : clouds) {
      ++n.messages;
      long non_finite = 0;
      if (!MessageBytes(message, &bytes) || !ReadCloudMessage(bytes, &msg) ||
          !DecodeCloud(msg, &cloud.points, &non_finite)) {
        ++n.malformed;
        continue;
      }
      const ros::Time stamp = StampOf(msg.stamp, message.getTime());
      cloud.t = stamp.toSec();
      if (tf != nullptr) {
        try {
          const geometry_msgs::Transform transform = tf->lookupTransform(world, StripSlash(msg.frame), stamp).transform;
          const Vec3 position(transform.translation.x, transform.translation.y, transform.translation.z);
          const Eigen::Vector4d wxyz(transform.rotation.w, transform.rotation.x, transform.rotation.y, transform.rotation.z);
          if (!ToPose(position, wxyz, &cloud.sensor_to_world)) {
            ++n.no_pose;
            continue;
          }
        } catch (const tf2::TransformException&) {
          ++n.no_pose;
          continue;
        }
      } else {
        Pose body;
        if (!odometry.At(cloud.t, source.max_pose_gap, &body)) {
          ++n.no_pose;
          continue;
        }
        cloud.sensor_to_world = body * source.extrinsic;
      }
      n.non_finite_points += non_finite;
      ++n.used;
      QUADHAND_RETURN_IF_ERROR(visit(cloud));
    }
  } catch (const std::exception& e) {
    return core::Status::InvalidArgument(source.path + ": not a readable ROS 1 bag (" + e.what() + ")");
  }
  return core::Status::Ok();
}

struct BagWriter::Impl {
  std::string path, partial;
  BagTopicsToWrite topics;
  rosbag::Bag bag;
  bool open = false;
};

BagWriter::BagWriter(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

BagWriter::~BagWriter() {
  if (impl_ != nullptr && impl_->open) {
    try {
      impl_->bag.close();
    } catch (const std::exception&) {
    }
    std::error_code ec;
    std::filesystem::remove(impl_->partial, ec);
  }
}

core::Result<std::unique_ptr<BagWriter>> BagWriter::Create(const std::string& path, const BagTopicsToWrite& topics) {
  QuietConsoleBridge();
  if (!(std::isfinite(topics.epoch) && topics.epoch > 0.0)) {
    return core::Status::InvalidArgument(path + ": the bag's epoch must be > 0 s");
  }
  auto impl = std::make_unique<Impl>();
  impl->path = path;
  impl->partial = path + core::Format(".partial.%d", static_cast<int>(getpid()));
  impl->topics = topics;
  try {
    impl->bag.open(impl->partial, rosbag::bagmode::Write);
  } catch (const std::exception& e) {
    return core::Status::InvalidArgument(path + ": cannot write a bag (" + e.what() + ")");
  }
  impl->open = true;
  return std::unique_ptr<BagWriter>(new BagWriter(std::move(impl)));
}

namespace {

core::Result<ros::Time> StampToWrite(const std::string& path, bool open, double t, double epoch) {
  if (!open) return core::Status::InvalidArgument(path + ": the bag is closed");
  if (!std::isfinite(t) || t + epoch <= 0.0) {
    return core::Status::InvalidArgument(path + ": a frame's time must be finite and after the epoch");
  }
  return ros::Time(t + epoch);
}


}  // namespace

core::Status BagWriter::Write(double t, const Pose& base_to_world, const Pose& sensor_to_base,
                              const std::vector<Vec3>& points) {
  QUADHAND_RETURN_IF_ERROR(WritePose(t, base_to_world, sensor_to_base));
  return WriteCloud(t, points);
}

core::Status BagWriter::WritePose(double t, const Pose& base_to_world, const Pose& sensor_to_base) {
  auto stamp = StampToWrite(impl_->path, impl_->open, t, impl_->topics.epoch);
  if (!stamp.ok()) return stamp.status();
  const BagTopicsToWrite& names = impl_->topics;
  const geometry_msgs::TransformStamped base = TransformOf(base_to_world, *stamp, names.world_frame, names.base_frame);
  nav_msgs::Odometry odom;
  odom.header = base.header;
  odom.child_frame_id = names.base_frame;
  odom.pose.pose.position.x = base.transform.translation.x;
  odom.pose.pose.position.y = base.transform.translation.y;
  odom.pose.pose.position.z = base.transform.translation.z;
  odom.pose.pose.orientation = base.transform.rotation;
  tf2_msgs::TFMessage tf;
  tf.transforms.push_back(base);
  tf.transforms.push_back(TransformOf(sensor_to_base, *stamp, names.base_frame, names.sensor_frame));
  try {
    impl_->bag.write("/tf", *stamp, tf);
    impl_->bag.write(names.odom_topic, *stamp, odom);
  } catch (const std::exception& e) {
    return core::Status::InvalidArgument(impl_->path + ": cannot write the bag (" + e.what() + ")");
  }
  return core::Status::Ok();
}

core::Status BagWriter::WriteCloud(double t, const std::vector<Vec3>& points) {
  auto stamp = StampToWrite(impl_->path, impl_->open, t, impl_->topics.epoch);
  if (!stamp.ok()) return stamp.status();
  sensor_msgs::PointCloud2 cloud;
  cloud.header.stamp = *stamp;
  cloud.header.frame_id = impl_->topics.sensor_frame;
  cloud.height = 1;
  cloud.width = static_cast<uint32_t>(points.size());
  const char* axes[3] = {"x", "y", "z"};
  for (int axis = 0; axis < 3; ++axis) {
    sensor_msgs::PointField field;
    field.name = axes[axis];
    field.offset = static_cast<uint32_t>(4 * axis);
    field.datatype = sensor_msgs::PointField::FLOAT32;
    field.count = 1;
    cloud.fields.push_back(field);
  }
  cloud.is_bigendian = false;
  cloud.point_step = 12;
  cloud.row_step = 12 * cloud.width;
  cloud.is_dense = true;
  cloud.data.resize(cloud.row_step);
  for (size_t i = 0; i < points.size(); ++i) {
    const float xyz[3] = {static_cast<float>(points[i].x()), static_cast<float>(points[i].y()),
                          static_cast<float>(points[i].z())};
    std::memcpy(cloud.data.data() + 12 * i, xyz, 12);
  }
  try {
    impl_->bag.write(impl_->topics.cloud_topic, *stamp, cloud);
  } catch (const std::exception& e) {
    return core::Status::InvalidArgument(impl_->path + ": cannot write the bag (" + e.what() + ")");
  }
  return core::Status::Ok();
}

core::Status BagWriter::Close() {
  if (!impl_->open) return core::Status::Ok();
  try {
    impl_->bag.close();
  } catch (const std::exception& e) {
    return core::Status::InvalidArgument(impl_->path + ": cannot finish the bag (" + e.what() + ")");
  }
  impl_->open = false;
  std::error_code ec;
  std::filesystem::rename(impl_->partial, impl_->path, ec);
  if (ec) {
    std::filesystem::remove(impl_->partial, ec);
    return core::Status::InvalidArgument(impl_->path + ": " + ec.message());
  }
  return core::Status::Ok();
}

}  // namespace quadhand::scene
