#include "quadhand/geometry/repaired_mesh_cache.h"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <optional>
#include <string_view>
#include <utility>
#include <vector>

#include "quadhand/core/file_util.h"
#include "quadhand/core/hash.h"
#include "quadhand/geometry/mesh_io.h"

#include "mesh_check_memo.h"

namespace quadhand::geometry {
namespace {

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
              "the mesh cache format is little-endian; add byte swapping for this platform");

constexpr char kMagic[8] = {'Q', 'H', 'M', 'E', 'S', 'H', '\n', '\x1a'};
constexpr uint32_t kFormatVersion = 1;
// Far above any link mesh (ReadMeshShells refuses larger files), far below
// what a corrupted count could ask to allocate.
constexpr uint64_t kMaxElements = 1ull << 27;

// The report's counts, in their order in the file.
std::vector<long*> Counts(MeshRepairReport* r) {
  return {&r->merged_vertices,  &r->degenerate_faces,   &r->duplicate_faces,
          &r->reversed_duplicate_pairs, &r->reversed_duplicate_faces, &r->flipped_faces,
          &r->outward_shells,   &r->shells,             &r->soup_points_merged,
          &r->soup_faces_removed};
}

template <typename T>
void Put(std::string* out, const T& value) {
  out->append(reinterpret_cast<const char*>(&value), sizeof(T));
}

void PutKey(std::string* out, const RepairedMeshCacheKey& key) {
  Put<uint32_t>(out, kMeshRepairRevision);
  Put<uint64_t>(out, key.source_hash);
  Put<uint64_t>(out, key.source_size);
  Put<double>(out, key.options.tolerance);
  Put<double>(out, key.options.metres_per_unit);
  const Eigen::Matrix<double, 3, 4> placement = key.placement.affine();
  for (int column = 0; column < 4; ++column) {
    for (int row = 0; row < 3; ++row) Put<double>(out, placement(row, column));
  }
  for (int i = 0; i < 3; ++i) Put<double>(out, key.scale[i]);
}

// The key's size in the file.
constexpr size_t kKeyBytes = 4 + 8 + 8 + 8 + 8 + 12 * 8 + 3 * 8;

class Reader {
 public:
  Reader(const std::string& bytes, size_t end) : bytes_(bytes), end_(end) {}
  template <typename T>
  bool Get(T* value) {
    if (end_ - offset_ < sizeof(T)) return false;
    std::memcpy(value, bytes_.data() + offset_, sizeof(T));
    offset_ += sizeof(T);
    return true;
  }
  bool GetBytes(void* data, size_t size) {
    if (end_ - offset_ < size) return false;
    std::memcpy(data, bytes_.data() + offset_, size);
    offset_ += size;
    return true;
  }
  size_t offset() const { return offset_; }

 private:
  const std::string& bytes_;
  size_t end_;
  size_t offset_ = 0;
};

}  // namespace

core::Result<RepairedMeshCacheKey> RepairedMeshCacheKeyOf(const std::string& path, const MeshRepairOptions& options) {
  RepairedMeshCacheKey key;
  key.options = options;
  // No larger file is a mesh (ReadMeshShells refuses it, naming the limit).
  if (const core::MappedFile file(path, kMaxMeshBytes); file.mapped()) {
    key.source_hash = core::FastHash64(file.bytes().data(), file.bytes().size());
    key.source_size = file.bytes().size();
    return key;
  }
  auto bytes = core::ReadFileToString(path, kMaxMeshBytes);
  if (!bytes.ok()) return bytes.status();
  key.source_hash = core::FastHash64(bytes->data(), bytes->size());
  key.source_size = bytes->size();
  return key;
}

std::string RepairedMeshCachePath(const std::string& cache_dir, const RepairedMeshCacheKey& key) {
  std::string bytes;
  PutKey(&bytes, key);
  char name[32];
  std::snprintf(name, sizeof(name), "%016llx.qhmesh",
                static_cast<unsigned long long>(core::FastHash64(bytes.data(), bytes.size())));
  return (std::filesystem::path(cache_dir) / name).string();
}

core::Status WriteRepairedMeshCache(const std::string& path, const RepairedMeshCacheKey& key,
                                    const RepairedMesh& repaired) {
  if (!repaired.report.problem.empty() || repaired.shells.empty()) {
    return core::Status::InvalidArgument(path + ": only shells that bound a volume are cached");
  }
  std::string out;
  out.append(kMagic, sizeof(kMagic));
  Put<uint32_t>(&out, kFormatVersion);
  PutKey(&out, key);
  MeshRepairReport report = repaired.report;
  for (long* count : Counts(&report)) Put<int64_t>(&out, *count);
  Put<uint64_t>(&out, repaired.shells.size());
  for (const TriangleMesh& shell : repaired.shells) {
    Put<uint64_t>(&out, shell.vertices.size());
    Put<uint64_t>(&out, shell.triangles.size());
    out.append(reinterpret_cast<const char*>(shell.vertices.data()), shell.vertices.size() * sizeof(Vec3));
    out.append(reinterpret_cast<const char*>(shell.triangles.data()),
               shell.triangles.size() * sizeof(Eigen::Vector3i));
  }
  core::AppendFastHash64Checksum(&out);
  std::error_code error;
  std::filesystem::create_directories(std::filesystem::path(path).parent_path(), error);
  if (error) return core::Status::InvalidArgument(path + ": cannot create its folder: " + error.message());
  return core::WriteFileAtomically(path, out);
}

core::Result<RepairedMesh> ReadRepairedMeshCache(const std::string& path, const RepairedMeshCacheKey& key) {
  std::error_code error;
  if (!std::filesystem::exists(path, error)) return core::Status::NotFound(path + ": no cached repair");
  auto bytes = core::ReadFileToString(path);
  if (!bytes.ok()) return bytes.status();
  auto invalid = [&path](const std::string& why) {
    return core::Status::InvalidArgument(path + ": not a usable repaired-mesh cache entry: " + why);
  };
  static_assert(sizeof(Vec3) == 3 * sizeof(double) && sizeof(Eigen::Vector3i) == 3 * sizeof(int));
  if (bytes->size() < sizeof(kMagic) + sizeof(uint64_t) || std::memcmp(bytes->data(), kMagic, sizeof(kMagic)) != 0) {
    return invalid("bad magic bytes");
  }
  const std::optional<std::string_view> body = core::FastHash64ChecksummedBody(*bytes);
  if (!body) return invalid("checksum mismatch (file corrupted)");
  const size_t end = body->size();

  Reader r(*bytes, end);
  char magic[sizeof(kMagic)];
  r.GetBytes(magic, sizeof(magic));
  uint32_t version = 0;
  if (!r.Get(&version) || version != kFormatVersion) return invalid("format version " + std::to_string(version));
  std::string expected_key, stored_key(kKeyBytes, '\0');
  PutKey(&expected_key, key);
  if (!r.GetBytes(stored_key.data(), stored_key.size())) return invalid("truncated");
  if (stored_key != expected_key) {
    return invalid("written for another mesh file, placement, options or repair revision");
  }

  RepairedMesh repaired;
  for (long* count : Counts(&repaired.report)) {
    int64_t value = 0;
    if (!r.Get(&value) || value < 0) return invalid("truncated or negative repair count");
    *count = static_cast<long>(value);
  }
  uint64_t num_shells = 0;
  if (!r.Get(&num_shells) || num_shells == 0 || num_shells > kMaxElements) return invalid("bad shell count");
  repaired.shells.resize(num_shells);
  for (TriangleMesh& shell : repaired.shells) {
    uint64_t num_vertices = 0, num_triangles = 0;
    if (!r.Get(&num_vertices) || !r.Get(&num_triangles) || num_vertices < 4 || num_triangles < 4 ||
        num_vertices > kMaxElements || num_triangles > kMaxElements) {
      return invalid("bad vertex or triangle count");
    }
    shell.vertices.resize(num_vertices);
    shell.triangles.resize(num_triangles);
    if (!r.GetBytes(shell.vertices.data(), num_vertices * sizeof(Vec3)) ||
        !r.GetBytes(shell.triangles.data(), num_triangles * sizeof(Eigen::Vector3i))) {
      return invalid("truncated");
    }
    for (const Vec3& v : shell.vertices) {
      if (!v.allFinite()) return invalid("a non-finite vertex");
    }
    const int limit = static_cast<int>(num_vertices);
    for (const Eigen::Vector3i& t : shell.triangles) {
      if ((t.array() < 0).any() || (t.array() >= limit).any()) return invalid("a triangle indexes a missing vertex");
    }
  }
  if (r.offset() != end) return invalid("trailing bytes");
  for (const TriangleMesh& shell : repaired.shells) RememberMeshBoundsVolume(shell);
  return repaired;
}

}  // namespace quadhand::geometry
