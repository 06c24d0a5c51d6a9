// Cached surface samples: what an entry gives back is exactly what sampling
// gives; another mesh or spacing, or a corrupted entry, samples afresh.
#include "quadhand/env/surface_sample_cache.h"

#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>

#include "quadhand/core/file_util.h"
#include "quadhand/core/hash.h"
#include "quadhand/geometry/primitives.h"

namespace quadhand::env {
namespace {

void ExpectSame(const LinkSurfaceSamples& a, const LinkSurfaceSamples& b) {
  EXPECT_EQ(a.points, b.points);
  EXPECT_EQ(a.vertices, b.vertices);
  ASSERT_EQ(a.clusters.size(), b.clusters.size());
  for (size_t i = 0; i < a.clusters.size(); ++i) {
    EXPECT_EQ(a.clusters[i].begin, b.clusters[i].begin);
    EXPECT_EQ(a.clusters[i].end, b.clusters[i].end);
    EXPECT_EQ(a.clusters[i].center, b.clusters[i].center);
    EXPECT_EQ(a.clusters[i].radius, b.clusters[i].radius);
  }
}

TEST(SurfaceSampleCacheTest, AnEntryIsReadForItsMeshAndSpacingOnly) {
  const std::string dir = (std::filesystem::temp_directory_path() / ("quadhand_samples_" + std::to_string(getpid()))).string();
  std::filesystem::remove_all(dir);
  const geometry::TriangleMesh box = geometry::TessellateBox(geometry::Box{Pose::Identity(), Vec3(0.1, 0.05, 0.2)});
  const geometry::TriangleMesh other = geometry::TessellateBox(geometry::Box{Pose::Identity(), Vec3(0.1, 0.05, 0.21)});
  const LinkSurfaceSamples fresh = SampleLinkSurface(box, 0.01);
  ExpectSame(CachedLinkSurfaceSamples(box, 0.01, dir), fresh);  // no entry yet
  ASSERT_TRUE(WriteLinkSurfaceSamples(box, 0.01, dir).ok());
  ExpectSame(CachedLinkSurfaceSamples(box, 0.01, dir), fresh);
  ExpectSame(CachedLinkSurfaceSamples(box, 0.02, dir), SampleLinkSurface(box, 0.02));
  ExpectSame(CachedLinkSurfaceSamples(other, 0.01, dir), SampleLinkSurface(other, 0.01));

  // The one entry, forged: its first sample moved, the checksum recomputed.
  // Read back, the forgery shows that the cache is read; with the checksum
  // left stale it is ignored.
  std::string entry;
  for (const auto& file : std::filesystem::directory_iterator(dir)) entry = file.path().string();
  auto bytes = core::ReadFileToString(entry);
  ASSERT_TRUE(bytes.ok());
  const size_t first_point = 8 + 4 + (4 + 8 + 8 + 8 + 8 + 8) + 3 * 8 + fresh.vertices.size() * sizeof(Vec3);
  std::string forged = *bytes;
  const double moved = fresh.points[0].x() + 1.0;
  std::memcpy(&forged[first_point], &moved, sizeof(moved));
  std::string stale = forged;
  const uint64_t checksum = core::FastHash64(forged.data(), forged.size() - 8);
  std::memcpy(&forged[forged.size() - 8], &checksum, sizeof(checksum));
  std::ofstream(entry, std::ios::binary | std::ios::trunc) << forged;
  EXPECT_EQ(CachedLinkSurfaceSamples(box, 0.01, dir).points[0].x(), moved);
  std::ofstream(entry, std::ios::binary | std::ios::trunc) << stale;
  ExpectSame(CachedLinkSurfaceSamples(box, 0.01, dir), fresh);
  std::ofstream(entry, std::ios::binary | std::ios::trunc) << bytes->substr(0, 40);
  ExpectSame(CachedLinkSurfaceSamples(box, 0.01, dir), fresh);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace quadhand::env
