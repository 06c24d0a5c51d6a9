#include "quadhand/geometry/sdf_grid.h"

#include <cstdint>
#include <algorithm>
#include <cstring>
#include <string_view>
#include <limits>

#include "quadhand/core/file_util.h"
#include "quadhand/core/hash.h"

namespace quadhand::geometry {
namespace {

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
              "the SDF file format is little-endian; add byte swapping for this platform");

constexpr char kMagic[8] = {'Q', 'H', 'S', 'D', 'F', '\n', '\x1a', '\0'};
constexpr uint32_t kFlagSigned = 1u;
// Strings longer than this mean a corrupted header rather than a real name.
constexpr uint32_t kMaxStringBytes = 4096;

class Writer {
 public:
  template <typename T>
  void Put(const T& value) {
    out_.append(reinterpret_cast<const char*>(&value), sizeof(T));
  }
  void PutVec3(const Vec3& v) {
    for (int i = 0; i < 3; ++i) Put<double>(v[i]);
  }
  void PutString(const std::string& s) {
    Put<uint32_t>(static_cast<uint32_t>(s.size()));
    out_.append(s);
  }
  void PutBytes(const void* data, size_t size) { out_.append(static_cast<const char*>(data), size); }
  std::string& bytes() { return out_; }

 private:
  std::string out_;
};

class Reader {
 public:
  explicit Reader(std::string_view bytes) : bytes_(bytes) {}
  template <typename T>
  bool Get(T* value) {
    if (bytes_.size() - offset_ < sizeof(T)) return false;
    std::memcpy(value, bytes_.data() + offset_, sizeof(T));
    offset_ += sizeof(T);
    return true;
  }
  bool GetVec3(Vec3* v) { return Get(&v->x()) && Get(&v->y()) && Get(&v->z()); }
  bool GetString(std::string* s) {
    uint32_t size = 0;
    if (!Get(&size) || size > kMaxStringBytes || bytes_.size() - offset_ < size) return false;
    s->assign(bytes_.data() + offset_, size);
    offset_ += size;
    return true;
  }
  size_t offset() const { return offset_; }

 private:
  std::string_view bytes_;
  size_t offset_ = 0;
};

}  // namespace

SdfGrid::SdfGrid(SdfGridInfo info, std::vector<float> values)
    : info_(std::move(info)), values_(std::move(values)) {
  inverse_resolution_ = info_.resolution > 0.0 ? 1.0 / info_.resolution : 0.0;
  stride_y_ = static_cast<size_t>(info_.dims.x());
  stride_z_ = stride_y_ * static_cast<size_t>(info_.dims.y());
  BuildBlockMinima();
}

void SdfGrid::BuildBlockMinima() {
  block_min_.clear();
  bstride_y_ = bstride_z_ = 0;
  const Eigen::Vector3i& n = info_.dims;
  if ((n.array() < 2).any() || values_.size() != static_cast<size_t>(info_.NumNodes())) return;
  // Blocks of kBlockCells cells per axis (the last one may be shorter).
  Eigen::Vector3i blocks = Eigen::Vector3i::Zero();
  for (int a = 0; a < 3; ++a) blocks[a] = (n[a] - 1 + kBlockCells - 1) / kBlockCells;
  bstride_y_ = static_cast<size_t>(blocks.x());
  bstride_z_ = bstride_y_ * static_cast<size_t>(blocks.y());
  // Separable: minima over each block's x range, then y, then z. A node on
  // a block face belongs to both blocks: block b spans nodes [b B, b B + B].
  auto reduce = [](const std::vector<float>& in, int axis_len, int blocks_along, size_t inner, size_t outer) {
    std::vector<float> out(inner * blocks_along * outer);
    for (size_t o = 0; o < outer; ++o) {
      for (int b = 0; b < blocks_along; ++b) {
        const int first = b * kBlockCells, last = std::min(first + kBlockCells, axis_len - 1);
        for (size_t i = 0; i < inner; ++i) {
          float m = std::numeric_limits<float>::infinity();
          for (int a = first; a <= last; ++a) m = std::min(m, in[i + inner * (a + static_cast<size_t>(axis_len) * o)]);
          out[i + inner * (b + static_cast<size_t>(blocks_along) * o)] = m;
        }
      }
    }
    return out;
  };
  const size_t ny = n.y(), nz = n.z();
  std::vector<float> along_x = reduce(values_, n.x(), blocks.x(), 1, ny * nz);           // bx * ny * nz
  std::vector<float> along_y = reduce(along_x, n.y(), blocks.y(), blocks.x(), nz);        // bx * by * nz
  block_min_ = reduce(along_y, n.z(), blocks.z(), bstride_z_, 1);                         // bx * by * bz
}

bool SdfGrid::EvaluateOutside(const Vec3& p, double* distance, Vec3* gradient) const {
  const Vec3 closest = p.cwiseMax(info_.geometry_min).cwiseMin(info_.geometry_max);
  const Vec3 offset = p - closest;
  const double d = offset.stableNorm();  // no overflow for far-away points
  *distance = d;
  if (gradient != nullptr) *gradient = d > 0.0 ? Vec3(offset / d) : Vec3::Zero();
  return false;
}

std::string SdfGrid::Serialize() const {
  Writer w;
  w.PutBytes(kMagic, sizeof(kMagic));
  w.Put<uint32_t>(kFormatVersion);
  w.Put<uint32_t>(info_.is_signed ? kFlagSigned : 0u);
  w.Put<double>(info_.resolution);
  w.PutVec3(info_.origin);
  for (int i = 0; i < 3; ++i) w.Put<uint32_t>(static_cast<uint32_t>(info_.dims[i]));
  w.PutVec3(info_.geometry_min);
  w.PutVec3(info_.geometry_max);
  w.PutString(info_.link_name);
  w.PutString(info_.frame);
  w.PutString(info_.source);
  w.Put<uint64_t>(values_.size());
  w.PutBytes(values_.data(), values_.size() * sizeof(float));
  core::AppendFastHash64Checksum(&w.bytes());
  return std::move(w.bytes());
}

core::Result<SdfGrid> SdfGrid::Deserialize(const std::string& bytes, const std::string& name) {
  return DeserializeView(bytes, name);
}

core::Result<SdfGrid> SdfGrid::DeserializeView(std::string_view bytes, const std::string& name) {
  auto invalid = [&name](const std::string& why) {
    return core::Status::InvalidArgument(name + ": not a valid QuadHand SDF file: " + why);
  };
  if (bytes.size() < sizeof(kMagic) || std::memcmp(bytes.data(), kMagic, sizeof(kMagic)) != 0) {
    return invalid("bad magic bytes (expected a file written by quadhand-sdfgen)");
  }
  Reader r(bytes);
  char magic[sizeof(kMagic)];
  for (char& c : magic) r.Get(&c);
  uint32_t version = 0;
  if (!r.Get(&version)) return invalid("truncated header");
  if (version < kOldestReadableVersion || version > kFormatVersion) {
    return invalid("format version " + std::to_string(version) + ", this build reads versions " +
                   std::to_string(kOldestReadableVersion) + " to " + std::to_string(kFormatVersion) +
                   " (regenerate it with quadhand-sdfgen)");
  }
  SdfGridInfo info;
  uint32_t flags = 0;
  uint32_t dims[3] = {0, 0, 0};
  uint64_t count = 0;
  const bool header_read = r.Get(&flags) && r.Get(&info.resolution) && r.GetVec3(&info.origin) &&
                           r.Get(&dims[0]) && r.Get(&dims[1]) && r.Get(&dims[2]) &&
                           r.GetVec3(&info.geometry_min) && r.GetVec3(&info.geometry_max) &&
                           r.GetString(&info.link_name) && r.GetString(&info.frame) &&
                           r.GetString(&info.source) && r.Get(&count);
  if (!header_read) return invalid("truncated or corrupted header");
  if ((flags & ~kFlagSigned) != 0) return invalid("unknown flags " + std::to_string(flags));
  info.is_signed = (flags & kFlagSigned) != 0;
  info.file_version = version;
  if (!(std::isfinite(info.resolution) && info.resolution > 0.0)) return invalid("resolution is not positive");
  if (!info.origin.allFinite() || !info.geometry_min.allFinite() || !info.geometry_max.allFinite()) {
    return invalid("non-finite origin or bounds");
  }
  for (int i = 0; i < 3; ++i) {
    if (dims[i] < 2 || dims[i] > (1u << 20)) return invalid("grid dimensions out of range");
    info.dims[i] = static_cast<int>(dims[i]);
  }
  if (count != static_cast<uint64_t>(info.NumNodes())) return invalid("value count does not match dimensions");
  const size_t expected_size = r.offset() + count * sizeof(float) + sizeof(uint64_t);
  if (bytes.size() != expected_size) {
    return invalid((bytes.size() < expected_size ? "truncated: " : "trailing bytes: ") +
                   std::to_string(bytes.size()) + " bytes, expected " + std::to_string(expected_size));
  }
  std::vector<float> values(count);
  std::memcpy(values.data(), bytes.data() + r.offset(), count * sizeof(float));
  uint64_t stored_checksum = 0;
  std::memcpy(&stored_checksum, bytes.data() + expected_size - sizeof(uint64_t), sizeof(uint64_t));
  const size_t hashed = expected_size - sizeof(uint64_t);
  const uint64_t checksum =
      version == 1 ? core::Fnv1a64(bytes.data(), hashed) : core::FastHash64(bytes.data(), hashed);
  if (stored_checksum != checksum) {
    return invalid("checksum mismatch (file corrupted)");
  }
  for (float v : values) {
    if (!std::isfinite(v)) return invalid("non-finite distance value");
  }
  return SdfGrid(std::move(info), std::move(values));
}

core::Result<SdfGrid> SdfGrid::Load(const std::string& path) {
  // Mapped, the file is hashed and its values copied once, straight from
  // the page cache: no buffer of the file's size to allocate and fill.
  if (const core::MappedFile file(path); file.mapped()) {
    return DeserializeView(file.bytes(), path);
  }
  core::Result<std::string> bytes = core::ReadFileToString(path);
  if (!bytes.ok()) return bytes.status();
  return Deserialize(*bytes, path);
}

}  // namespace quadhand::geometry
