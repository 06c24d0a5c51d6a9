// A simulated range sensor (docs/sim.md, "Sensors"): a depth camera or a
// LiDAR, mounted on a link of the robot, rendering the hidden true scene as
// the points it would return. The scene is a point cloud: each point is a
// disc of `splat_radius` facing the sensor, and the nearest one along a
// pixel's (or a beam's) direction occludes everything behind it.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/core/types.h"

namespace quadhand::sim {

// A pinhole depth camera. Its frame: z along the optical axis, x to the
// right of the image, y down (the usual optical frame). The defaults are a
// common stereo depth camera's: 640 x 480, 87 x 58 degrees, 0.2 to 6 m at
// 30 Hz.
struct DepthCameraOptions {
  int width = 640, height = 480;  // pixels
  double horizontal_fov_deg = 87.0, vertical_fov_deg = 58.0;
  double min_range = 0.2, max_range = 6.0;  // m, along the optical axis
  double rate = 30.0;                       // frames per second
  // Depth noise: zero-mean Gaussian of `noise_at_1m * z^2` (stereo depth's
  // error grows with the square of the depth), m at 1 m.
  double noise_at_1m = 0.002;
  bool IsValid(std::string* why) const;
};

// A spinning LiDAR. Its frame: x forward, z up; `channels` beams evenly
// spaced over [-vertical_fov/2, vertical_fov/2] of elevation, one return per
// `horizontal_resolution_deg` of azimuth over the full turn.
struct LidarOptions {
  int channels = 16;
  double vertical_fov_deg = 30.0;
  double horizontal_resolution_deg = 0.4;
  double min_range = 0.3, max_range = 30.0;  // m
  double rate = 10.0;                        // turns (frames) per second
  double noise = 0.01;                       // m, range noise (one sigma)
  bool IsValid(std::string* why) const;
};

enum class SensorKind { kDepth, kLidar };

// Which sensor, where it is mounted (the sensor's frame in `link`'s frame;
// default: 0.1 m ahead of the base's origin, looking forward: the camera's
// z along the base's x), and how each point of the scene is drawn.
struct SensorConfig {
  SensorKind kind = SensorKind::kDepth;
  DepthCameraOptions depth;
  LidarOptions lidar;
  std::string link = "base_link";
  Pose mount = Pose::Identity();  // when mount_given; read Mount()
  bool mount_given = false;
  // The radius of the disc each scene point stands for, m: wide enough for
  // the scene's point spacing to leave no holes at the ranges that matter.
  double splat_radius = 0.02;
  // 0: every disc has splat_radius. > 0: a point's disc is at most this
  // times the distance to its nearest other point (and at most
  // splat_radius), so that a densely sampled object is not drawn fatter
  // than its sampling needs: a cup sampled every 5 mm is drawn 4 mm off its
  // surface at 0.75, not 2 cm (a surface on a square grid of spacing s
  // needs discs of s / sqrt(2) to show no holes: at least 0.71).
  double splat_spacing_factor = 0.0;
  double rate() const { return kind == SensorKind::kDepth ? depth.rate : lidar.rate; }
  double max_range() const { return kind == SensorKind::kDepth ? depth.max_range : lidar.max_range; }
  // The sensor's frame in `link`'s: the mount given, else DefaultMount(kind).
  Pose Mount() const;
  bool IsValid(std::string* why) const;
};

// The default mount: 0.1 m ahead of the link origin, looking along its x
// (for a depth camera: optical z along x, image x along -y, image y along -z).
Pose DefaultMount(SensorKind kind);

// "depth" or "lidar" (InvalidArgument otherwise).
core::Result<SensorKind> ParseSensorKind(const std::string& name);

// The distance within which the given fraction of the world's points
// have their nearest other point (over up to `samples` of them, evenly
// strided; duplicates are not neighbours): 0.9 gives the spacing of all
// but the sparsest tenth. 0 for fewer than two distinct points, or none
// within 2 m. A surface sampled on a square grid of spacing s has holes
// s / sqrt(2) from its points: discs of a smaller splat_radius let the
// sensor see through them (docs/sim.md, "Points as discs").
double PointSpacing(const std::vector<Vec3>& world, double quantile = 0.9, size_t samples = 4000);

class SensorRenderer {
 public:
  // The world's points are indexed once. InvalidArgument for bad options,
  // an empty world or a non-finite point.
  static core::Result<std::unique_ptr<SensorRenderer>> Create(const std::vector<Vec3>& world,
                                                              const SensorConfig& config, std::uint64_t seed);
  ~SensorRenderer();

  // One frame from the sensor at `sensor_in_world`: the returned points, in
  // the sensor's frame, noisy (seeded: the same frames for the same seed
  // and sequence of calls).
  std::vector<Vec3> Render(const Pose& sensor_in_world);
  // The last Render's pixels (or beams) that saw nothing within the
  // sensor's range and nothing nearer than its minimum range (which would
  // hide what is behind): the far end of each, in the sensor's frame, at
  // max_range (a depth camera: at depth max_range). Every `stride`-th along
  // each image axis (a LiDAR: along its columns), stride >= 1. What a map
  // may mark free along the ray: true in this simulator; for a real sensor
  // an assumption (a dark or shiny surface also returns nothing).
  std::vector<Vec3> LastMisses(int stride) const;

  const SensorConfig& config() const;

 private:
  struct Impl;
  explicit SensorRenderer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace quadhand::sim
