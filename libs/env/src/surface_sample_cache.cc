#include "quadhand/env/surface_sample_cache.h"

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <optional>
#include <string_view>

#include "quadhand/core/file_util.h"
#include "quadhand/core/hash.h"

namespace quadhand::env {
namespace {

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
              "the sample cache format is little-endian; add byte swapping for this platform");
static_assert(sizeof(Vec3) == 3 * sizeof(double) && sizeof(Eigen::Vector3i) == 3 * sizeof(int));

constexpr char kMagic[8] = {'Q', 'H', 'S', 'M', 'P', 'L', '\n', '\x1a'};
constexpr uint32_t kFormatVersion = 1;
constexpr uint64_t kMaxCount = 1ull << 28;  // far above any link's samples

// The key: the sampling revision, the mesh's exact bytes (hashed), the spacing and the cluster size.
std::string KeyBytes(const geometry::TriangleMesh& mesh, double spacing, double cluster_size) {
  std::string key;
  auto put = [&key](const auto& value) { key.append(reinterpret_cast<const char*>(&value), sizeof(value)); };
  put(kSurfaceSamplingRevision);
  const uint64_t vertices = core::FastHash64(mesh.vertices.data(), mesh.vertices.size() * sizeof(Vec3));
  put(core::FastHash64(mesh.triangles.data(), mesh.triangles.size() * sizeof(Eigen::Vector3i), vertices));
  put(static_cast<uint64_t>(mesh.vertices.size()));
  put(static_cast<uint64_t>(mesh.triangles.size()));
  put(spacing);
  put(cluster_size);
  return key;
}

std::string EntryPath(const std::string& cache_dir, const std::string& key) {
  char name[40];
  std::snprintf(name, sizeof(name), "%016llx.qhsamples",
                static_cast<unsigned long long>(core::FastHash64(key.data(), key.size())));
  return (std::filesystem::path(cache_dir) / name).string();
}

// The entry's samples, or false when it is missing, of another key or corrupted.
bool ReadEntry(const std::string& path, const std::string& key, LinkSurfaceSamples* out) {
  const core::MappedFile file(path);
  if (!file.mapped()) return false;
  const std::string_view bytes = file.bytes();
  if (bytes.size() < sizeof(kMagic) + 4 + key.size() + 3 * 8 + 8) return false;
  const std::optional<std::string_view> body = core::FastHash64ChecksummedBody(bytes);
  if (!body) return false;
  const size_t end = body->size();
  size_t at = 0;
  auto get = [&](void* data, size_t size) {
    if (end - at < size) return false;
    std::memcpy(data, bytes.data() + at, size);
    at += size;
    return true;
  };
  char magic[sizeof(kMagic)];
  uint32_t version = 0;
  std::string stored_key(key.size(), '\0');
  if (!get(magic, sizeof(magic)) || std::memcmp(magic, kMagic, sizeof(kMagic)) != 0) return false;
  if (!get(&version, sizeof(version)) || version != kFormatVersion) return false;
  if (!get(stored_key.data(), stored_key.size()) || stored_key != key) return false;
  uint64_t counts[3] = {0, 0, 0};  // vertices, points, clusters
  if (!get(counts, sizeof(counts))) return false;
  for (uint64_t count : counts) {
    if (count > kMaxCount) return false;
  }
  LinkSurfaceSamples samples;
  samples.vertices.resize(counts[0]);
  samples.points.resize(counts[1]);
  samples.clusters.resize(counts[2]);
  if (!get(samples.vertices.data(), counts[0] * sizeof(Vec3)) || !get(samples.points.data(), counts[1] * sizeof(Vec3))) {
    return false;
  }
  for (LinkSurfaceSamples::Cluster& c : samples.clusters) {
    int32_t range[2];
    double sphere[4];
    if (!get(range, sizeof(range)) || !get(sphere, sizeof(sphere))) return false;
    if (range[0] < 0 || range[0] > range[1] || static_cast<uint64_t>(range[1]) > counts[1]) return false;
    c.begin = range[0];
    c.end = range[1];
    c.center = Vec3(sphere[0], sphere[1], sphere[2]);
    c.radius = sphere[3];
  }
  if (at != end) return false;
  *out = std::move(samples);
  return true;
}

}  // namespace

LinkSurfaceSamples CachedLinkSurfaceSamples(const geometry::TriangleMesh& mesh, double spacing,
                                            const std::string& cache_dir, double cluster_size) {
  if (!cache_dir.empty()) {
    const std::string key = KeyBytes(mesh, spacing, cluster_size);
    LinkSurfaceSamples cached;
    if (ReadEntry(EntryPath(cache_dir, key), key, &cached)) return cached;
  }
  return SampleLinkSurface(mesh, spacing, cluster_size);
}

core::Status WriteLinkSurfaceSamples(const geometry::TriangleMesh& mesh, double spacing, const std::string& cache_dir,
                                     double cluster_size) {
  const LinkSurfaceSamples samples = SampleLinkSurface(mesh, spacing, cluster_size);
  const std::string key = KeyBytes(mesh, spacing, cluster_size);
  std::string out;
  auto put = [&out](const void* data, size_t size) { out.append(static_cast<const char*>(data), size); };
  put(kMagic, sizeof(kMagic));
  put(&kFormatVersion, sizeof(kFormatVersion));
  put(key.data(), key.size());
  const uint64_t counts[3] = {samples.vertices.size(), samples.points.size(), samples.clusters.size()};
  put(counts, sizeof(counts));
  put(samples.vertices.data(), samples.vertices.size() * sizeof(Vec3));
  put(samples.points.data(), samples.points.size() * sizeof(Vec3));
  for (const LinkSurfaceSamples::Cluster& c : samples.clusters) {
    const int32_t range[2] = {c.begin, c.end};
    const double sphere[4] = {c.center.x(), c.center.y(), c.center.z(), c.radius};
    put(range, sizeof(range));
    put(sphere, sizeof(sphere));
  }
  core::AppendFastHash64Checksum(&out);
  std::error_code error;
  std::filesystem::create_directories(cache_dir, error);
  if (error) return core::Status::InvalidArgument(cache_dir + ": cannot create the folder: " + error.message());
  return core::WriteFileAtomically(EntryPath(cache_dir, key), out);
}

}  // namespace quadhand::env
