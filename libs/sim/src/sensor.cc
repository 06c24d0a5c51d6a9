#include "quadhand/sim/sensor.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <random>

#include "quadhand/core/text.h"
#include "quadhand/scene/point_grid.h"

namespace quadhand::sim {
namespace {

constexpr double kDegree = M_PI / 180.0;

bool Fail(std::string* why, const std::string& message) {
  if (why != nullptr) *why = message;
  return false;
}

bool In(double x, double lo, double hi) { return std::isfinite(x) && x >= lo && x <= hi; }

// The depth camera's pinhole: focal lengths and image centre, pixels.
struct Pinhole {
  explicit Pinhole(const DepthCameraOptions& o)
      : fx(0.5 * o.width / std::tan(0.5 * o.horizontal_fov_deg * kDegree)),
        fy(0.5 * o.height / std::tan(0.5 * o.vertical_fov_deg * kDegree)),
        cx(0.5 * o.width),
        cy(0.5 * o.height) {}
  // The point at depth z on the ray through pixel (col, row)'s centre.
  Vec3 PointAt(int col, int row, double z) const { return Vec3((col + 0.5 - cx) / fx * z, (row + 0.5 - cy) / fy * z, z); }
  double fx, fy, cx, cy;
};

// The LiDAR's beams: channel c at elevation low + c * channel_step, column
// a at azimuth a * column_step (a may run past a turn).
struct BeamPattern {
  explicit BeamPattern(const LidarOptions& o)
      : columns(std::max(1, static_cast<int>(std::lround(360.0 / o.horizontal_resolution_deg)))),
        column_step(2.0 * M_PI / columns),
        low(-0.5 * o.vertical_fov_deg * kDegree),
        channel_step(o.channels > 1 ? o.vertical_fov_deg * kDegree / (o.channels - 1) : 0.0) {}
  // The point at `range` along beam (channel, column).
  Vec3 PointAt(int channel, int column, double range) const {
    const double elevation = low + channel * channel_step, azimuth = column * column_step;
    return Vec3(range * std::cos(elevation) * std::cos(azimuth), range * std::cos(elevation) * std::sin(azimuth),
                range * std::sin(elevation));
  }
  int columns;
  double column_step, low, channel_step;
};

// What a point at `measure` (the camera's depth, the LiDAR's range) writes
// into the pixels or beams its disc covers: 0 when it is too near to
// measure (it still hides what is behind it, so they are no misses), none
// when it is out of range.
std::optional<float> SplatValue(double measure, double min_range, double max_range) {
  const bool too_near = measure > 1e-6 && measure < min_range;
  if (!too_near && !(measure >= min_range && measure <= max_range)) return std::nullopt;
  return too_near ? 0.0f : static_cast<float>(measure);
}

}  // namespace

bool DepthCameraOptions::IsValid(std::string* why) const {
  if (width < 1 || width > 8192 || height < 1 || height > 8192) {
    return Fail(why, "depth.width and depth.height must be in [1, 8192] pixels");
  }
  if (!In(horizontal_fov_deg, 1.0, 170.0) || !In(vertical_fov_deg, 1.0, 170.0)) {
    return Fail(why, "depth.horizontal_fov_deg and depth.vertical_fov_deg must be in [1, 170] degrees");
  }
  if (!In(min_range, 0.01, 1000.0) || !In(max_range, 0.01, 1000.0) || !(min_range < max_range)) {
    return Fail(why, "depth.min_range and depth.max_range must be in [0.01, 1000] m, min below max");
  }
  if (!In(rate, 0.1, 1000.0)) return Fail(why, "depth.rate must be in [0.1, 1000] Hz");
  if (!In(noise_at_1m, 0.0, 1.0)) return Fail(why, "depth.noise_at_1m must be in [0, 1] m");
  return true;
}

bool LidarOptions::IsValid(std::string* why) const {
  if (channels < 1 || channels > 1024) return Fail(why, "lidar.channels must be in [1, 1024]");
  if (!In(vertical_fov_deg, 0.0, 180.0)) return Fail(why, "lidar.vertical_fov_deg must be in [0, 180] degrees");
  if (channels > 1 && !(vertical_fov_deg > 0.0)) return Fail(why, "lidar.vertical_fov_deg must be positive with several channels");
  if (!In(horizontal_resolution_deg, 0.01, 90.0)) {
    return Fail(why, "lidar.horizontal_resolution_deg must be in [0.01, 90] degrees");
  }
  if (!In(min_range, 0.01, 1000.0) || !In(max_range, 0.01, 1000.0) || !(min_range < max_range)) {
    return Fail(why, "lidar.min_range and lidar.max_range must be in [0.01, 1000] m, min below max");
  }
  if (!In(rate, 0.1, 1000.0)) return Fail(why, "lidar.rate must be in [0.1, 1000] Hz");
  if (!In(noise, 0.0, 1.0)) return Fail(why, "lidar.noise must be in [0, 1] m");
  return true;
}

bool SensorConfig::IsValid(std::string* why) const {
  if (kind == SensorKind::kDepth && !depth.IsValid(why)) return false;
  if (kind == SensorKind::kLidar && !lidar.IsValid(why)) return false;
  if (link.empty()) return Fail(why, "link must name a link of the robot");
  if (!mount.matrix().allFinite()) return Fail(why, "mount must be finite");
  if (!In(splat_radius, 1e-4, 1.0)) return Fail(why, "splat_radius must be in [0.0001, 1] m");
  if (!(splat_spacing_factor == 0.0 || In(splat_spacing_factor, 0.5, 10.0))) {
    return Fail(why, "splat_spacing_factor must be 0 (off) or in [0.5, 10]");
  }
  return true;
}

Pose DefaultMount(SensorKind kind) {
  Mat3 rotation = Mat3::Identity();
  if (kind == SensorKind::kDepth) {
    // Columns: the camera's x, y, z in the link's frame.
    rotation << 0.0, 0.0, 1.0,  //
        -1.0, 0.0, 0.0,         //
        0.0, -1.0, 0.0;
  }
  return MakePose(Vec3(0.1, 0.0, 0.0), rotation);
}

Pose SensorConfig::Mount() const { return mount_given ? mount : DefaultMount(kind); }

core::Result<SensorKind> ParseSensorKind(const std::string& name) {
  if (name == "depth") return SensorKind::kDepth;
  if (name == "lidar") return SensorKind::kLidar;
  return core::Status::InvalidArgument("sensor: expected depth or lidar, not '" + name + "'");
}

// The world's points by the radius of their discs (splat_spacing_factor):
// one layer of all of them at splat_radius, or one per radius, the radii
// rounded up to the millimetre so that the layers are few.
struct SplatLayer {
  double radius = 0.0;
  scene::PointGrid points;
};

std::vector<SplatLayer> SplatLayers(const std::vector<Vec3>& world, const SensorConfig& config) {
  std::vector<SplatLayer> layers;
  if (config.splat_spacing_factor <= 0.0) {
    layers.push_back(SplatLayer{config.splat_radius, scene::PointGrid(world, 0.25)});
    return layers;
  }
  const double cap = config.splat_radius;
  // A neighbour farther than cap / factor leaves the disc at the cap.
  const double reach = cap / config.splat_spacing_factor;
  const scene::PointGrid grid(world, std::max(reach, 0.01));
  std::map<long, std::vector<Vec3>> by_radius;  // in millimetres, rounded up
  for (const Vec3& p : world) {
    double nearest = std::numeric_limits<double>::infinity();
    grid.VisitBox(p - Vec3::Constant(reach), p + Vec3::Constant(reach), [&](const Vec3& q) {
      const double d = (q - p).norm();
      if (d > 1e-9 && d < nearest) nearest = d;
    });
    const double radius = std::min(cap, config.splat_spacing_factor * nearest);
    by_radius[static_cast<long>(std::ceil(radius * 1000.0 - 1e-9))].push_back(p);
  }
  for (auto& [millimetres, points] : by_radius) {
    layers.push_back(SplatLayer{std::min(cap, millimetres / 1000.0), scene::PointGrid(points, 0.25)});
  }
  return layers;
}

struct SensorRenderer::Impl {
  SensorConfig config;
  std::vector<SplatLayer> layers;
  std::mt19937_64 rng;
  std::vector<float> nearest;  // per pixel or beam: the nearest return, m (infinity: none)
  Impl(const std::vector<Vec3>& points, const SensorConfig& c, std::uint64_t seed)
      : config(c), layers(SplatLayers(points, c)), rng(seed) {}

  std::vector<Vec3> RenderDepth(const Pose& sensor_in_world);
  std::vector<Vec3> RenderLidar(const Pose& sensor_in_world);
};

SensorRenderer::SensorRenderer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
SensorRenderer::~SensorRenderer() = default;

const SensorConfig& SensorRenderer::config() const { return impl_->config; }

double PointSpacing(const std::vector<Vec3>& world, double quantile, size_t samples) {
  if (world.size() < 2 || samples == 0 || !(quantile >= 0.0 && quantile <= 1.0)) return 0.0;
  const scene::PointGrid grid(world, 0.05);
  const size_t stride = std::max<size_t>(1, world.size() / samples);
  std::vector<double> nearest;
  for (size_t i = 0; i < world.size(); i += stride) {
    const Vec3& p = world[i];
    if (!p.allFinite()) continue;
    for (double reach = 0.05; reach <= 2.0; reach *= 2.0) {
      double best = std::numeric_limits<double>::infinity();
      grid.VisitBox(p - Vec3::Constant(reach), p + Vec3::Constant(reach), [&](const Vec3& q) {
        const double d = (q - p).norm();
        if (d > 1e-9 && d < best) best = d;
      });
      // Only a neighbour within the box's inscribed ball is surely the nearest.
      if (best <= reach) {
        nearest.push_back(best);
        break;
      }
    }
  }
  if (nearest.empty()) return 0.0;
  const size_t at = std::min(nearest.size() - 1, static_cast<size_t>(quantile * static_cast<double>(nearest.size())));
  std::nth_element(nearest.begin(), nearest.begin() + static_cast<long>(at), nearest.end());
  return nearest[at];
}

core::Result<std::unique_ptr<SensorRenderer>> SensorRenderer::Create(const std::vector<Vec3>& world,
                                                                     const SensorConfig& config, std::uint64_t seed) {
  if (std::string why; !config.IsValid(&why)) return core::Status::InvalidArgument("sensor: " + why);
  if (world.empty()) return core::Status::InvalidArgument("sensor: the world has no points");
  for (const Vec3& p : world) {
    if (!p.allFinite()) return core::Status::InvalidArgument("sensor: the world has a non-finite point");
  }
  return std::unique_ptr<SensorRenderer>(new SensorRenderer(std::make_unique<Impl>(world, config, seed)));
}

std::vector<Vec3> SensorRenderer::Render(const Pose& sensor_in_world) {
  return impl_->config.kind == SensorKind::kDepth ? impl_->RenderDepth(sensor_in_world)
                                                  : impl_->RenderLidar(sensor_in_world);
}

std::vector<Vec3> SensorRenderer::LastMisses(int stride) const {
  const Impl& m = *impl_;
  stride = std::max(1, stride);
  const float none = std::numeric_limits<float>::infinity();
  std::vector<Vec3> ends;
  if (m.config.kind == SensorKind::kDepth) {
    const DepthCameraOptions& o = m.config.depth;
    if (m.nearest.size() != static_cast<size_t>(o.width) * o.height) return ends;
    const Pinhole camera(o);
    for (int row = stride / 2; row < o.height; row += stride) {
      for (int col = stride / 2; col < o.width; col += stride) {
        if (m.nearest[static_cast<size_t>(row) * o.width + col] == none) ends.push_back(camera.PointAt(col, row, o.max_range));
      }
    }
    return ends;
  }
  const LidarOptions& o = m.config.lidar;
  const BeamPattern beams(o);
  if (m.nearest.size() != static_cast<size_t>(o.channels) * beams.columns) return ends;
  for (int channel = 0; channel < o.channels; ++channel) {
    for (int column = 0; column < beams.columns; column += stride) {
      if (m.nearest[static_cast<size_t>(channel) * beams.columns + column] == none) {
        ends.push_back(beams.PointAt(channel, column, o.max_range));
      }
    }
  }
  return ends;
}

std::vector<Vec3> SensorRenderer::Impl::RenderDepth(const Pose& sensor_in_world) {
  const DepthCameraOptions& o = config.depth;
  const Pinhole camera(o);
  const double fx = camera.fx, fy = camera.fy, cx = camera.cx, cy = camera.cy;
  const float none = std::numeric_limits<float>::infinity();
  nearest.assign(static_cast<size_t>(o.width) * o.height, none);
  const Pose world_to_sensor = sensor_in_world.inverse();
  const Vec3 reach = Vec3::Constant(o.max_range + config.splat_radius);
  for (const SplatLayer& layer : layers) {
    const double splat = layer.radius;
    layer.points.VisitBox(sensor_in_world.translation() - reach, sensor_in_world.translation() + reach, [&](const Vec3& p) {
      const Vec3 q = world_to_sensor * p;
      const double z = q.z();
      const std::optional<float> value = SplatValue(z, o.min_range, o.max_range);
      if (!value) return;
      // The point's disc, facing the camera, covers a square of half-width r
      // pixels about its projection (a circle: the corners are dropped).
      const double u = cx + fx * q.x() / z, v = cy + fy * q.y() / z;
      const double ru = fx * splat / z, rv = fy * splat / z;
      const int u0 = std::max(0, static_cast<int>(std::floor(u - ru))), u1 = std::min(o.width - 1, static_cast<int>(std::floor(u + ru)));
      const int v0 = std::max(0, static_cast<int>(std::floor(v - rv))), v1 = std::min(o.height - 1, static_cast<int>(std::floor(v + rv)));
      for (int row = v0; row <= v1; ++row) {
        const double dv = (row + 0.5 - v) / rv;
        for (int col = u0; col <= u1; ++col) {
          const double du = (col + 0.5 - u) / ru;
          if (du * du + dv * dv > 1.0) continue;
          float& depth = nearest[static_cast<size_t>(row) * o.width + col];
          depth = std::min(depth, *value);
        }
      }
    });
  }
  std::normal_distribution<double> unit(0.0, 1.0);
  std::vector<Vec3> points;
  for (int row = 0; row < o.height; ++row) {
    for (int col = 0; col < o.width; ++col) {
      const float depth = nearest[static_cast<size_t>(row) * o.width + col];
      if (depth == none || depth == 0.0f) continue;
      const double z = depth + o.noise_at_1m * depth * depth * unit(rng);
      if (!(z > 0.0)) continue;
      points.push_back(camera.PointAt(col, row, z));
    }
  }
  return points;
}

std::vector<Vec3> SensorRenderer::Impl::RenderLidar(const Pose& sensor_in_world) {
  const LidarOptions& o = config.lidar;
  const BeamPattern beams(o);
  const int columns = beams.columns;
  const double column_step = beams.column_step, low = beams.low, channel_step = beams.channel_step;
  const float none = std::numeric_limits<float>::infinity();
  nearest.assign(static_cast<size_t>(o.channels) * columns, none);
  const Pose world_to_sensor = sensor_in_world.inverse();
  const Vec3 reach = Vec3::Constant(o.max_range + config.splat_radius);
  for (const SplatLayer& layer : layers) {
    layer.points.VisitBox(sensor_in_world.translation() - reach, sensor_in_world.translation() + reach, [&](const Vec3& p) {
      const Vec3 q = world_to_sensor * p;
      const double range = q.norm();
      const std::optional<float> value = SplatValue(range, o.min_range, o.max_range);
      if (!value) return;
      // The disc's angular radius about the point's direction: the beams
      // within it hit it.
      const double spread = std::asin(std::min(1.0, layer.radius / range));
      const double azimuth = std::atan2(q.y(), q.x()), elevation = std::asin(q.z() / range);
      int c0 = 0, c1 = 0;
      if (o.channels > 1) {
        c0 = std::max(0, static_cast<int>(std::ceil((elevation - spread - low) / channel_step)));
        c1 = std::min(o.channels - 1, static_cast<int>(std::floor((elevation + spread - low) / channel_step)));
      } else if (std::abs(elevation) > spread) {
        return;
      }
      const double horizontal = std::min(M_PI, spread / std::max(1e-9, std::cos(elevation)));
      const int a0 = static_cast<int>(std::ceil((azimuth - horizontal) / column_step));
      const int a1 = static_cast<int>(std::floor((azimuth + horizontal) / column_step));
      for (int channel = c0; channel <= c1; ++channel) {
        for (int a = a0; a <= a1; ++a) {
          // The angle between the beam and the point's direction.
          const Vec3 beam = beams.PointAt(channel, a, 1.0);
          if (beam.dot(q) < range * std::cos(spread)) continue;
          const int column = ((a % columns) + columns) % columns;
          float& hit = nearest[static_cast<size_t>(channel) * columns + column];
          hit = std::min(hit, *value);
        }
      }
    });
  }
  std::normal_distribution<double> unit(0.0, 1.0);
  std::vector<Vec3> points;
  for (int channel = 0; channel < o.channels; ++channel) {
    for (int column = 0; column < columns; ++column) {
      const float hit = nearest[static_cast<size_t>(channel) * columns + column];
      if (hit == none || hit == 0.0f) continue;
      const double range = hit + o.noise * unit(rng);
      if (!(range > 0.0)) continue;
      points.push_back(beams.PointAt(channel, column, range));
    }
  }
  return points;
}

}  // namespace quadhand::sim
