#include "quadhand/geometry/mesh_to_sdf.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <exception>
#include <limits>
#include <memory>
#include <mutex>
#include <thread>
#include <utility>
#include <vector>

#include "quadhand/core/text.h"
#include "quadhand/geometry/mesh_distance.h"
#include "quadhand/geometry/mesh_io.h"

namespace quadhand::geometry {
namespace {

// 2e8 float nodes are 800 MB: beyond that a typo in the resolution is far
// more likely than a real need.
constexpr double kMaxNodes = 2e8;

std::string Format(double value) { return core::Format("%g", value); }

bool InBox(const Vec3& p, const AxisAlignedBox& box) {
  return (p.array() >= box.min.array()).all() && (p.array() <= box.max.array()).all();
}

// One collision element of the grid's geometry: its distance query and
// bounding box.
struct Element {
  const MeshDistanceQuery* query;
  AxisAlignedBox box;
};

// Fills the values of slice z = k: at each node the smallest signed distance
// over the elements (exact outside their union). Each slice depends only on
// its own queries, so the result does not depend on how slices are spread
// over threads.
void ComputeSlice(const std::vector<Element>& elements, const SdfGridInfo& info, int k, std::vector<float>* values) {
  const double h = info.resolution;
  const double same_side_threshold = h * (1.0 + 1e-9);
  const size_t slice_offset = static_cast<size_t>(k) * info.dims.x() * info.dims.y();
  // Per element: the closest point of the previous node (and of the row's
  // first), a good first guess that lets the tree prune most of its boxes.
  struct Walk {
    Vec3 row_hint = Vec3::Zero(), hint = Vec3::Zero();
    bool have_row_hint = false, have_hint = false;
    // At the previous node: its unsigned distance (or a lower bound of it,
    // when the element was skipped there) and whether it was inside.
    double previous_distance = 0.0;
    bool previous_inside = false;
    bool have_previous = false;
  };
  // A skipped element's bound loses h per node; the margin keeps rounding in
  // the distances from ever skipping an element that would set the minimum.
  const double step_bound = h * (1.0 + 1e-9);
  std::vector<Walk> walks(elements.size());
  std::vector<std::pair<double, size_t>> order(elements.size());
  for (int j = 0; j < info.dims.y(); ++j) {
    for (Walk& w : walks) {
      w.hint = w.row_hint;
      w.have_hint = w.have_row_hint;
      w.have_previous = false;
    }
    for (int i = 0; i < info.dims.x(); ++i) {
      const Vec3 p = info.origin + h * Vec3(i, j, k);
      // A lower bound of each element's signed distance here: distance is
      // 1-Lipschitz, so a node h beyond an outside node at distance d > h is
      // outside at distance >= d - h (-inf when nothing is known). Elements
      // are measured nearest bound first; one whose bound is no less than
      // the smallest distance measured so far cannot set the minimum and is
      // skipped (the value is the same, bit for bit). This is what makes a
      // link of several meshes cost little more than its nearest one.
      for (size_t e = 0; e < elements.size(); ++e) {
        const Walk& w = walks[e];
        const bool outside_beyond_step = w.have_previous && !w.previous_inside && w.previous_distance > step_bound;
        order[e] = {outside_beyond_step ? w.previous_distance - step_bound
                                        : -std::numeric_limits<double>::infinity(),
                    e};
      }
      if (elements.size() > 1) std::sort(order.begin(), order.end());
      double value = std::numeric_limits<double>::infinity();
      for (const auto& [lower_bound, e] : order) {
        Walk& w = walks[e];
        if (lower_bound >= value) {
          w.previous_distance = lower_bound;
          w.previous_inside = false;
          continue;
        }
        const MeshDistanceQuery& query = *elements[e].query;
        Vec3 closest;
        const double distance = w.have_hint ? query.UnsignedDistanceWithHint(p, w.hint, &closest)
                                            : query.UnsignedDistance(p, &closest);
        w.hint = closest;
        w.have_hint = true;
        if (i == 0) {
          w.row_hint = closest;
          w.have_row_hint = true;
        }
        bool inside = false;
        // Outside the element's bounding box every point is outside it.
        // Two neighbouring nodes a, b on opposite sides of the surface have a
        // surface point s between them, so d(a) + d(b) <= |a - s| + |s - b|
        // = h. Hence d(a) + d(b) > h (or a lower bound of d(a) plus d(b))
        // means they share a side and the costly inside test (a ray cast)
        // can be skipped. The margin absorbs rounding in d.
        if (query.is_signed() && InBox(p, elements[e].box)) {
          inside = (w.have_previous && w.previous_distance + distance > same_side_threshold) ? w.previous_inside
                                                                                              : query.IsInside(p);
        }
        value = std::min(value, inside ? -distance : distance);
        w.previous_distance = distance;
        w.previous_inside = inside;
      }
      for (Walk& w : walks) w.have_previous = true;
      (*values)[slice_offset + static_cast<size_t>(j) * info.dims.x() + i] = static_cast<float>(value);
    }
  }
}

}  // namespace

bool SdfGenerationOptions::IsValid(std::string* why) const {
  auto fail = [why](const std::string& message) {
    if (why != nullptr) *why = message;
    return false;
  };
  // A link SDF coarser than a metre describes no link; beyond that the grid
  // node coordinates overflow.
  if (!(resolution > 0.0 && resolution <= 1.0)) {
    return fail("resolution must be in (0, 1] m, got " + Format(resolution));
  }
  if (!(padding >= 0.0 && padding <= 10.0)) {
    return fail("padding must be in [0, 10] m, got " + Format(padding));
  }
  if (num_threads < 0 || num_threads > 256) {
    return fail("num_threads must be in [0, 256] (0: all hardware threads), got " + std::to_string(num_threads));
  }
  // Even a point-sized mesh gets a grid spanning twice the padding per axis.
  const double min_nodes_per_axis = std::floor(2.0 * padding / resolution) + 1.0;
  if (std::pow(min_nodes_per_axis, 3) > kMaxNodes) {
    return fail("padding " + Format(padding) + " m at resolution " + Format(resolution) +
                " m alone needs more than " + Format(kMaxNodes) +
                " grid nodes; use a coarser resolution or less padding");
  }
  return true;
}

namespace {

// Nodes along each axis of the grid over `box` plus the padding.
core::Result<Eigen::Vector3i> GridDims(const AxisAlignedBox& box, const SdfGenerationOptions& options) {
  const Vec3 extent = box.size() + Vec3::Constant(2.0 * options.padding);
  Eigen::Vector3i dims;
  double num_nodes = 1.0;
  for (int axis = 0; axis < 3; ++axis) {
    // The relative slack keeps an extent that is an exact multiple of the
    // resolution from gaining a node through rounding.
    const double cells = std::ceil(extent[axis] / options.resolution * (1.0 - 1e-12));
    num_nodes *= cells + 1.0;
    if (!(num_nodes <= kMaxNodes)) {
      return core::Status::InvalidArgument("the grid would have more than " + Format(kMaxNodes) +
                                           " nodes; use a coarser resolution or less padding");
    }
    dims[axis] = static_cast<int>(cells) + 1;
  }
  return dims;
}

}  // namespace

core::Result<Eigen::Vector3i> SdfGridDims(const std::vector<TriangleMesh>& meshes,
                                          const SdfGenerationOptions& options) {
  AxisAlignedBox box;
  bool any = false;
  for (const TriangleMesh& mesh : meshes) {
    if (mesh.vertices.empty()) continue;
    const AxisAlignedBox element = BoundingBox(mesh);
    box.min = any ? box.min.cwiseMin(element.min) : element.min;
    box.max = any ? box.max.cwiseMax(element.max) : element.max;
    any = true;
  }
  if (!any) return core::Status::InvalidArgument("no collision geometry");
  return GridDims(box, options);
}

core::Result<SdfGrid> GenerateSdf(const TriangleMesh& mesh, const std::string& link_name,
                                  const std::string& source, const SdfGenerationOptions& options,
                                  const ProgressCallback& progress) {
  return GenerateSdf(std::vector<TriangleMesh>{mesh}, link_name, source, options, progress);
}

core::Result<SdfGrid> GenerateSdf(const std::vector<TriangleMesh>& meshes, const std::string& link_name,
                                  const std::string& source, const SdfGenerationOptions& options,
                                  const ProgressCallback& progress) {
  const std::string what = "SDF of link '" + link_name + "' (" + source + ")";
  std::string why;
  if (!options.IsValid(&why)) return core::Status::InvalidArgument(what + ": " + why);
  if (meshes.empty()) return core::Status::InvalidArgument(what + ": no collision geometry");
  std::vector<std::unique_ptr<MeshDistanceQuery>> queries;
  std::vector<Element> elements;
  bool all_signed = true;
  AxisAlignedBox box;
  for (size_t e = 0; e < meshes.size(); ++e) {
    const TriangleMesh& mesh = meshes[e];
    const std::string element = meshes.size() > 1 ? " collision element " + std::to_string(e + 1) : "";
    if (mesh.triangles.empty() || mesh.vertices.empty()) {
      return core::Status::InvalidArgument(what + ":" + element + (element.empty() ? " the mesh is empty" : " is empty"));
    }
    const MeshCheck check = CheckMesh(mesh);
    if (!check.bounds_volume && !options.allow_unsigned) {
      return core::Status::InvalidArgument(
          what + ":" + (element.empty() ? " the mesh" : element) + " does not bound a volume (" + check.problem +
          "); allow unsigned distances to accept it");
    }
    // Unsigned elements make the whole grid unsigned: a minimum over signed
    // and unsigned distances has no consistent inside.
    all_signed = all_signed && check.bounds_volume;
    const AxisAlignedBox element_box = BoundingBox(mesh);
    if (e == 0) {
      box = element_box;
    } else {
      box.min = box.min.cwiseMin(element_box.min);
      box.max = box.max.cwiseMax(element_box.max);
    }
    elements.push_back({nullptr, element_box});
  }
  for (size_t e = 0; e < meshes.size(); ++e) {
    auto query_or = MeshDistanceQuery::Create(meshes[e], all_signed);
    if (!query_or.ok()) return query_or.status().WithPrefix(what);
    queries.push_back(std::move(*query_or));
    elements[e].query = queries.back().get();
  }

  SdfGridInfo info;
  info.link_name = link_name;
  info.frame = link_name;
  info.source = source;
  info.resolution = options.resolution;
  info.origin = box.min - Vec3::Constant(options.padding);
  info.is_signed = all_signed;
  info.geometry_min = box.min;
  info.geometry_max = box.max;
  auto dims = GridDims(box, options);
  if (!dims.ok()) return dims.status().WithPrefix(what);
  info.dims = *dims;

  const long total = info.NumNodes();
  std::vector<float> values(static_cast<size_t>(total));
  int num_threads = options.num_threads > 0
                        ? options.num_threads
                        : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  num_threads = std::min(num_threads, info.dims.z());

  std::atomic<int> next_slice{0};
  std::atomic<bool> failed{false};
  std::mutex mutex;  // guards `done`, `error` and the progress callback
  long done = 0;
  std::string error;
  auto worker = [&]() {
    for (;;) {
      const int k = next_slice.fetch_add(1);
      if (k >= info.dims.z() || failed.load()) return;
      try {
        ComputeSlice(elements, info, k, &values);
      } catch (const std::exception& e) {
        const std::lock_guard<std::mutex> lock(mutex);
        if (!failed.exchange(true)) error = e.what();
        return;
      }
      if (progress) {
        const std::lock_guard<std::mutex> lock(mutex);
        done += static_cast<long>(info.dims.x()) * info.dims.y();
        progress(done, total);
      }
    }
  };
  std::vector<std::thread> threads;
  for (int t = 1; t < num_threads; ++t) threads.emplace_back(worker);
  worker();  // the calling thread works too
  for (std::thread& thread : threads) thread.join();
  if (failed.load()) return core::Status::Internal(what + ": distance query failed: " + error);
  return SdfGrid(std::move(info), std::move(values));
}

}  // namespace quadhand::geometry
