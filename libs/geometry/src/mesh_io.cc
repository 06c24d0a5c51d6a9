// Mesh files, validity checks and boolean union with CGAL. This is one of
// the two translation units that include CGAL (each takes about a minute to
// compile); the rest of QuadHand sees only TriangleMesh.
#include "quadhand/geometry/mesh_io.h"

#include "mesh_check_memo.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <mutex>
#include <sstream>
#include <string>
#include <system_error>
#include <vector>

// GCC 12 reports a false -Wmaybe-uninitialized inside CGAL's self-intersection
// test when instantiated for Epeck (from corefinement); the pragma covers only
// CGAL's headers, where the warning is located.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
// Faces of more than three vertices are triangulated by hole filling, not
// by a 2-D constrained Delaunay triangulation of their projection: the CDT
// followed a null pointer on a degenerate face (found by fuzzing), hole
// filling triangulates any closed polygon.
#define CGAL_TRIANGULATE_FACES_DO_NOT_USE_CDT2
#include <CGAL/Exact_predicates_exact_constructions_kernel.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/IO/polygon_soup_io.h>
#include <CGAL/Polygon_mesh_processing/IO/polygon_mesh_io.h>
#include <CGAL/Polygon_mesh_processing/corefinement.h>
#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/orientation.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/repair_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Polygon_mesh_processing/shape_predicates.h>
#include <CGAL/Polygon_mesh_processing/triangulate_faces.h>
#include <CGAL/Surface_mesh.h>
#pragma GCC diagnostic pop

#include "assimp_mesh_reader.h"
#include "quadhand/core/file_util.h"
#include "quadhand/core/hash.h"
#include "quadhand/core/numbers.h"
#include "quadhand/core/ply_header.h"
#include "quadhand/geometry/mesh_repair.h"

namespace quadhand::geometry {
namespace {

namespace PMP = CGAL::Polygon_mesh_processing;
using InexactKernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using ExactKernel = CGAL::Exact_predicates_exact_constructions_kernel;
using InexactMesh = CGAL::Surface_mesh<InexactKernel::Point_3>;
using ExactMesh = CGAL::Surface_mesh<ExactKernel::Point_3>;
using Triangle = std::array<std::size_t, 3>;

// The longest line of a text OFF file checked before CGAL reads it.
constexpr std::size_t kMaxOffLineBytes = 65536;

std::string LowerCaseExtension(const std::string& path) {
  std::string extension = std::filesystem::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return extension;
}

bool IsSupportedExtension(const std::string& extension) {
  return extension == ".stl" || extension == ".obj" || extension == ".ply" || extension == ".off" ||
         extension == ".dae";
}

// Empty string if every triangle indexes existing vertices.
std::string IndexProblem(const TriangleMesh& mesh) {
  const int num_vertices = static_cast<int>(mesh.vertices.size());
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    const Eigen::Vector3i& triangle = mesh.triangles[t];
    if ((triangle.array() < 0).any() || (triangle.array() >= num_vertices).any()) {
      return "triangle " + std::to_string(t) + " indexes a vertex outside [0, " +
             std::to_string(num_vertices) + ")";
    }
  }
  return {};
}

std::vector<Triangle> TrianglesAsSoup(const TriangleMesh& mesh) {
  std::vector<Triangle> soup;
  soup.reserve(mesh.triangles.size());
  for (const Eigen::Vector3i& t : mesh.triangles) {
    soup.push_back({static_cast<std::size_t>(t[0]), static_cast<std::size_t>(t[1]),
                    static_cast<std::size_t>(t[2])});
  }
  return soup;
}

// Builds a CGAL surface mesh with the same vertices and triangles. Returns
// false if the triangles do not form a combinatorial manifold (CGAL's halfedge
// structure cannot hold an edge with three faces, or two faces that traverse
// an edge in the same direction).
template <typename Mesh>
bool ToSurfaceMesh(const TriangleMesh& mesh, Mesh* out) {
  using Point = typename Mesh::Point;
  const std::vector<Triangle> soup = TrianglesAsSoup(mesh);
  if (!PMP::is_polygon_soup_a_polygon_mesh(soup)) return false;
  std::vector<Point> points;
  points.reserve(mesh.vertices.size());
  for (const Vec3& v : mesh.vertices) points.emplace_back(v.x(), v.y(), v.z());
  PMP::polygon_soup_to_polygon_mesh(points, soup, *out);
  return true;
}

template <typename Mesh>
TriangleMesh FromSurfaceMesh(const Mesh& mesh) {
  TriangleMesh out;
  std::vector<int> index(mesh.number_of_vertices() + mesh.number_of_removed_vertices(), -1);
  out.vertices.reserve(mesh.number_of_vertices());
  for (auto v : mesh.vertices()) {
    const auto& p = mesh.point(v);
    index[v.idx()] = static_cast<int>(out.vertices.size());
    out.vertices.emplace_back(CGAL::to_double(p.x()), CGAL::to_double(p.y()),
                              CGAL::to_double(p.z()));
  }
  out.triangles.reserve(mesh.number_of_faces());
  for (auto f : mesh.faces()) {
    Eigen::Vector3i triangle;
    int corner = 0;
    for (auto v : CGAL::vertices_around_face(mesh.halfedge(f), mesh)) {
      if (corner < 3) triangle[corner] = index[v.idx()];
      ++corner;
    }
    if (corner == 3) out.triangles.push_back(triangle);
  }
  return out;
}

// The same mesh with vertices sorted lexicographically and triangles sorted
// (each rotated, orientation kept, to start at its smallest index). CGAL's
// corefinement emits the same triangles in an order that varies from run to
// run (it hashes addresses); canonical order makes outputs reproducible.
TriangleMesh CanonicalOrder(const TriangleMesh& mesh) {
  const auto lexicographic_less = [](const Vec3& a, const Vec3& b) {
    return std::lexicographical_compare(a.data(), a.data() + 3, b.data(), b.data() + 3);
  };
  std::vector<int> order(mesh.vertices.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return lexicographic_less(mesh.vertices[a], mesh.vertices[b]);
  });
  TriangleMesh out;
  std::vector<int> new_index(mesh.vertices.size());
  for (size_t i = 0; i < order.size(); ++i) {
    new_index[order[i]] = static_cast<int>(i);
    out.vertices.push_back(mesh.vertices[order[i]]);
  }
  for (const Eigen::Vector3i& t : mesh.triangles) {
    Eigen::Vector3i mapped(new_index[t[0]], new_index[t[1]], new_index[t[2]]);
    while (mapped[0] != mapped.minCoeff()) mapped = Eigen::Vector3i(mapped[1], mapped[2], mapped[0]);
    out.triangles.push_back(mapped);
  }
  std::sort(out.triangles.begin(), out.triangles.end(),
            [](const Eigen::Vector3i& a, const Eigen::Vector3i& b) {
              return std::lexicographical_compare(a.data(), a.data() + 3, b.data(), b.data() + 3);
            });
  return out;
}

// Shortest decimal text that reads back as the same double.
std::string Number(double value) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  return std::string(buffer, result.ptr);
}

std::string VertexLine(const char* prefix, const Vec3& v) {
  return prefix + Number(v.x()) + " " + Number(v.y()) + " " + Number(v.z()) + "\n";
}

template <typename T>
void AppendBytes(std::string* out, const T& value) {
  out->append(reinterpret_cast<const char*>(&value), sizeof(T));
}

std::string BinaryStl(const TriangleMesh& mesh) {
  static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "binary STL is little-endian");
  std::string out;
  out.reserve(84 + 50 * mesh.triangles.size());
  // The header must not start with "solid", or readers take the file for ASCII.
  char header[80] = {};
  std::strncpy(header, "QuadHand binary STL, metres", sizeof(header) - 1);
  out.append(header, sizeof(header));
  AppendBytes(&out, static_cast<uint32_t>(mesh.triangles.size()));
  for (const Eigen::Vector3i& t : mesh.triangles) {
    const Vec3& a = mesh.vertices[t[0]];
    const Vec3& b = mesh.vertices[t[1]];
    const Vec3& c = mesh.vertices[t[2]];
    Vec3 normal = (b - a).cross(c - a);
    if (normal.norm() > 0.0) normal.normalize();
    for (const Vec3* v : std::array<const Vec3*, 4>{&normal, &a, &b, &c}) {
      for (int i = 0; i < 3; ++i) AppendBytes(&out, static_cast<float>((*v)[i]));
    }
    AppendBytes(&out, static_cast<uint16_t>(0));  // attribute byte count
  }
  return out;
}

std::string AsciiOff(const TriangleMesh& mesh) {
  std::string out = "OFF\n" + std::to_string(mesh.vertices.size()) + " " +
                    std::to_string(mesh.triangles.size()) + " 0\n";
  for (const Vec3& v : mesh.vertices) out += VertexLine("", v);
  for (const Eigen::Vector3i& t : mesh.triangles) {
    out += "3 " + std::to_string(t[0]) + " " + std::to_string(t[1]) + " " + std::to_string(t[2]) +
           "\n";
  }
  return out;
}

std::string AsciiObj(const TriangleMesh& mesh) {
  std::string out = "# QuadHand mesh, metres\n";
  for (const Vec3& v : mesh.vertices) out += VertexLine("v ", v);
  for (const Eigen::Vector3i& t : mesh.triangles) {  // OBJ indices start at 1
    out += "f " + std::to_string(t[0] + 1) + " " + std::to_string(t[1] + 1) + " " +
           std::to_string(t[2] + 1) + "\n";
  }
  return out;
}

std::string AsciiPly(const TriangleMesh& mesh) {
  std::string out = "ply\nformat ascii 1.0\ncomment QuadHand mesh, metres\n";
  out += "element vertex " + std::to_string(mesh.vertices.size()) + "\n";
  out += "property double x\nproperty double y\nproperty double z\n";
  out += "element face " + std::to_string(mesh.triangles.size()) + "\n";
  out += "property list uchar int vertex_indices\nend_header\n";
  for (const Vec3& v : mesh.vertices) out += VertexLine("", v);
  for (const Eigen::Vector3i& t : mesh.triangles) {
    out += "3 " + std::to_string(t[0]) + " " + std::to_string(t[1]) + " " + std::to_string(t[2]) +
           "\n";
  }
  return out;
}

// CGAL's readers explain format errors on std::cerr. Capturing them keeps a
// failed read to one message (ours, carrying CGAL's reason) and a good read
// silent. std::cerr is global, so captures are serialised.
class CerrCapture {
 public:
  CerrCapture() : lock_(Mutex()), previous_(std::cerr.rdbuf(captured_.rdbuf())) {}
  ~CerrCapture() { std::cerr.rdbuf(previous_); }
  CerrCapture(const CerrCapture&) = delete;
  CerrCapture& operator=(const CerrCapture&) = delete;

  // The first captured line, or empty.
  std::string FirstLine() const {
    std::string text = captured_.str();
    text = text.substr(0, text.find('\n'));
    while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back()))) text.pop_back();
    return text;
  }

 private:
  static std::mutex& Mutex() {
    static std::mutex mutex;
    return mutex;
  }
  std::lock_guard<std::mutex> lock_;
  std::ostringstream captured_;
  std::streambuf* previous_;
};

// CGAL's PLY reader trusts the header: a "property" before any "element"
// is undefined behaviour there (found by fuzzing), and element counts size
// its buffers. The header is read strictly first (core::ParsePlyHeader),
// and vertex coordinates must be float or double (any other type was a null
// dereference in CGAL; found by fuzzing).
std::string PlyHeaderProblem(const std::string& path, std::uintmax_t file_size) {
  std::ifstream in(path, std::ios::binary);
  std::string start(65536, '\0');
  in.read(start.data(), static_cast<std::streamsize>(start.size()));
  start.resize(static_cast<std::size_t>(in.gcount()));
  auto header = core::ParsePlyHeader(start, file_size);
  if (!header.ok()) return header.status().message();
  for (const core::PlyElement& element : header->elements) {
    if (element.name != "vertex") continue;
    for (const core::PlyProperty& p : element.properties) {
      const bool coordinate = p.name == "x" || p.name == "y" || p.name == "z";
      if (coordinate && (p.is_list || core::PlyTypeSize(p.type) < 4 || p.type.find("int") != std::string::npos)) {
        return "PLY vertex coordinate '" + p.name + "' of type '" + p.type + "' (expected float or double)";
      }
    }
  }
  return "";
}

// CGAL's OFF scanner converts a face index written as a huge number to an
// integer without a check (undefined behaviour; found by fuzzing). For the
// plain ascii "OFF" form, the face lines are checked first: whole-number
// indices below the vertex count. (Variants such as COFF or binary OFF are
// left to CGAL.)
std::string OffTextProblem(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::vector<std::vector<std::string>> lines;
  std::string line;
  for (core::LineRead got; (got = core::ReadBoundedLine(in, kMaxOffLineBytes, &line)) != core::LineRead::kEnd;) {
    if (got == core::LineRead::kTooLong) return "an OFF line longer than 64 KiB";
    const std::size_t hash = line.find('#');
    if (hash != std::string::npos) line.erase(hash);
    std::istringstream words(line);
    std::vector<std::string> row;
    for (std::string w; words >> w;) row.push_back(w);
    if (!row.empty()) lines.push_back(std::move(row));
  }
  if (lines.empty()) return "empty OFF file";
  // CGAL also reads variants it matches loosely ("OFF-", 4OFF, nOFF,
  // binary): only the text forms whose vertex and face lines are checked
  // below are handed to it.
  // CGAL's scanner also reads colours and normals (COFF, NOFF, per-face
  // colours) without checking them (a heap overflow in its colour scanner;
  // found by fuzzing): only plain OFF, with three coordinates per vertex
  // line and nothing after a face's indices, is handed to it.
  const std::string& magic = lines[0][0];
  if (magic != "OFF") {
    std::string shown;
    for (char c : magic.substr(0, 16)) shown += std::isprint(static_cast<unsigned char>(c)) ? c : '?';
    return "OFF header '" + shown + "' is not supported (plain OFF only, without colours or normals)";
  }
  std::size_t next = 0;
  std::vector<std::string> counts(lines[0].begin() + 1, lines[0].end());
  if (counts.empty()) {
    if (lines.size() < 2) return "OFF file without vertex and face counts";
    counts = lines[1];
    next = 2;
  } else {
    next = 1;
  }
  auto whole = [](const std::string& text, std::uint64_t* value) {
    return core::ParseWholeNumber(text, 999999999999999999ULL, value);
  };
  std::uint64_t vertices = 0, faces = 0;
  // Exactly "vertices faces edges" on one line: CGAL reads tokens, not
  // lines, so a short counts line made it take the next line's number as
  // the edge count and then a face of 1.7e9 vertices (found by fuzzing).
  std::uint64_t edges = 0;
  if (counts.size() != 3 || !whole(counts[0], &vertices) || !whole(counts[1], &faces) || !whole(counts[2], &edges)) {
    return "OFF counts line must be three whole numbers (vertices, faces, edges)";
  }
  if (next + vertices + faces > lines.size()) return "OFF file has fewer lines than its counts say";
  for (std::size_t v = 0; v < vertices; ++v) {
    const std::vector<std::string>& row = lines[next + v];
    bool numbers = row.size() == 3;
    for (const std::string& word : row) {
      char* end = nullptr;
      const double value = std::strtod(word.c_str(), &end);
      numbers = numbers && end == word.c_str() + word.size() && std::isfinite(value);
    }
    if (!numbers) return "OFF vertex " + std::to_string(v + 1) + " is not three finite numbers";
  }
  for (std::size_t f = 0; f < faces; ++f) {
    const std::vector<std::string>& row = lines[next + vertices + f];
    std::uint64_t k = 0;
    if (!whole(row[0], &k) || k < 3 || k + 1 != row.size()) {
      return "OFF face " + std::to_string(f + 1) + ": bad vertex count (or a colour after the indices)";
    }
    for (std::size_t i = 1; i <= k; ++i) {
      std::uint64_t index = 0;
      if (!whole(row[i], &index) || index >= vertices) {
        return "OFF face " + std::to_string(f + 1) + " names a vertex the file does not have";
      }
    }
  }
  return "";
}

}  // namespace

namespace {

// The file's faces as a triangle soup, before any repair; false (and no
// soup) when a face has more than three corners.
bool AsTriangleSoup(const std::vector<InexactKernel::Point_3>& points, const std::vector<std::vector<std::size_t>>& polygons,
                  TriangleMesh* soup) {
  for (const auto& polygon : polygons) {
    if (polygon.size() != 3) return false;
  }
  soup->vertices.reserve(points.size());
  for (const auto& p : points) soup->vertices.emplace_back(p.x(), p.y(), p.z());
  soup->triangles.reserve(polygons.size());
  for (const auto& polygon : polygons) {
    soup->triangles.emplace_back(static_cast<int>(polygon[0]), static_cast<int>(polygon[1]),
                                 static_cast<int>(polygon[2]));
  }
  return true;
}

}  // namespace

core::Result<TriangleMesh> ReadMesh(const std::string& path) {
  auto shells = ReadMeshShells(path, MeshRepairOptions{}, nullptr);
  if (!shells.ok()) return shells.status();
  return shells->size() == 1 ? std::move(shells->front()) : Concatenated(*shells);
}

core::Result<std::vector<TriangleMesh>> ReadMeshShells(const std::string& path, const MeshRepairOptions& options,
                                                       MeshRepairReport* report) {
  if (std::string why; !options.IsValid(&why)) return core::Status::InvalidArgument(path + ": " + why);
  std::error_code error;
  if (!std::filesystem::exists(path, error)) {
    return core::Status::NotFound(path + ": no such mesh file");
  }
  if (!std::filesystem::is_regular_file(path, error)) {
    return core::Status::InvalidArgument(path + ": not a regular file");
  }
  const std::string extension = LowerCaseExtension(path);
  if (!IsSupportedExtension(extension)) {
    return core::Status::InvalidArgument(path + ": unsupported mesh format '" + extension +
                                         "' (expected .stl, .obj, .ply, .off or .dae)");
  }
  const std::uintmax_t file_size = std::filesystem::file_size(path, error);
  if (file_size == 0 || error) {
    return core::Status::InvalidArgument(path + ": empty mesh file");
  }
  if (file_size > kMaxMeshBytes) {
    return core::Status::InvalidArgument(path + ": mesh file of " + std::to_string(file_size) +
                                         " bytes, more than the " + std::to_string(kMaxMeshBytes >> 20) +
                                         " MiB a link mesh may have (simplify it)");
  }
  // Every format is read as a polygon soup first and checked here: CGAL's
  // readers do not check face indices (an OBJ face naming vertex 0 or one
  // past the last made the repair read out of bounds; found by fuzzing).
  std::vector<InexactKernel::Point_3> points;
  std::vector<std::vector<std::size_t>> polygons;
  std::string reader_message;
  if (extension == ".dae") {
    auto soup = ReadAssimpSoup(path);
    if (!soup.ok()) return soup.status();
    points.reserve(soup->vertices.size());
    for (const Vec3& v : soup->vertices) points.emplace_back(v.x(), v.y(), v.z());
    polygons.reserve(soup->triangles.size());
    for (const auto& t : soup->triangles) polygons.push_back({t[0], t[1], t[2]});
  } else {
    if (extension == ".ply") {
      const std::string problem = PlyHeaderProblem(path, file_size);
      if (!problem.empty()) return core::Status::InvalidArgument(path + ": " + problem);
    }
    if (extension == ".off") {
      const std::string problem = OffTextProblem(path);
      if (!problem.empty()) return core::Status::InvalidArgument(path + ": " + problem);
    }
    const CerrCapture capture;
    bool soup_read = false;
    try {
      soup_read = CGAL::IO::read_polygon_soup(path, points, polygons);
    } catch (const std::exception& e) {
      reader_message = e.what();
    }
    if (reader_message.empty()) reader_message = capture.FirstLine();
    if (!soup_read) {
      return core::Status::InvalidArgument(path + ": cannot read mesh (malformed " + extension.substr(1) + " file)" +
                                           (reader_message.empty() ? std::string() : ": " + reader_message));
    }
  }
  for (const auto& p : points) {
    if (!std::isfinite(p.x()) || !std::isfinite(p.y()) || !std::isfinite(p.z())) {
      return core::Status::InvalidArgument(path + ": mesh has a non-finite vertex");
    }
  }
  for (size_t f = 0; f < polygons.size(); ++f) {
    if (polygons[f].size() < 3) {
      return core::Status::InvalidArgument(path + ": face " + std::to_string(f + 1) + " has fewer than 3 vertices");
    }
    for (std::size_t index : polygons[f]) {
      if (index >= points.size()) {
        return core::Status::InvalidArgument(path + ": face " + std::to_string(f + 1) +
                                             " names a vertex the file does not have");
      }
    }
  }
  // A triangle soup (STL, most exports) goes through RepairMesh, which
  // counts what it changes and says truly what it cannot repair.
  TriangleMesh soup;
  std::string repair_problem;
  if (AsTriangleSoup(points, polygons, &soup)) {
    auto repaired = RepairMesh(soup, options);
    if (repaired.ok()) {
      if (report != nullptr) *report = repaired->report;
      return std::move(repaired->shells);
    }
    repair_problem = repaired.status().message();
  }
  // Polygons of more corners, and soups RepairMesh refused: what
  // read_polygon_mesh does after reading (merge duplicate points, drop
  // degenerate and duplicate faces, orient the soup, build the mesh), then
  // RepairMesh on the result.
  InexactMesh mesh;
  bool read = false;
  const size_t points_before = points.size(), polygons_before = polygons.size();
  PMP::repair_polygon_soup(points, polygons);
  // A face that visits a vertex twice (as written, or once duplicate points
  // are merged) is not a simple polygon: CGAL's face triangulation followed
  // a null pointer on one (found by fuzzing).
  for (size_t f = 0; f < polygons.size(); ++f) {
    std::vector<std::size_t> sorted = polygons[f];
    std::sort(sorted.begin(), sorted.end());
    if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end()) {
      return core::Status::InvalidArgument(path + ": a face visits one vertex twice (not a simple polygon)");
    }
  }
  PMP::orient_polygon_soup(points, polygons);
  if (!polygons.empty() && PMP::is_polygon_soup_a_polygon_mesh(polygons)) {
    PMP::polygon_soup_to_polygon_mesh(points, polygons, mesh);
    read = true;
  }
  if (!read) {
    if (!repair_problem.empty()) return core::Status::InvalidArgument(path + ": " + repair_problem);
    return core::Status::InvalidArgument(
        path + ": cannot read mesh (malformed " + extension.substr(1) +
        " file, or its faces do not form a manifold surface)" +
        (reader_message.empty() ? std::string() : ": " + reader_message));
  }
  if (mesh.number_of_faces() == 0) {
    return core::Status::InvalidArgument(path + ": mesh has no faces");
  }
  if (!CGAL::is_triangle_mesh(mesh) && !PMP::triangulate_faces(mesh)) {
    return core::Status::InvalidArgument(path + ": a face could not be triangulated (not a simple polygon)");
  }
  const TriangleMesh read_mesh = FromSurfaceMesh(mesh);
  auto repaired = RepairMesh(read_mesh, options);
  if (repaired.ok()) {
    if (report != nullptr) {
      *report = repaired->report;
      // What CGAL's soup repair changed is reported too: nothing is repaired silently.
      report->soup_points_merged = static_cast<long>(points_before - std::min(points_before, points.size()));
      report->soup_faces_removed = static_cast<long>(polygons_before - std::min(polygons_before, polygons.size()));
    }
    return std::move(repaired->shells);
  }
  // Not a volume: the mesh as read, for callers that accept open surfaces
  // (unsigned distances); the diagnosis of the soup when there was one.
  if (report != nullptr) {
    *report = MeshRepairReport{};
    report->problem = repair_problem.empty() ? repaired.status().message() : repair_problem;
  }
  return std::vector<TriangleMesh>{read_mesh};
}

core::Status WriteMesh(const std::string& path, const TriangleMesh& mesh) {
  const std::string index_problem = IndexProblem(mesh);
  if (!index_problem.empty()) {
    return core::Status::InvalidArgument("cannot write " + path + ": " + index_problem);
  }
  const std::string extension = LowerCaseExtension(path);
  std::string contents;
  if (extension == ".stl") {
    contents = BinaryStl(mesh);
  } else if (extension == ".off") {
    contents = AsciiOff(mesh);
  } else if (extension == ".obj") {
    contents = AsciiObj(mesh);
  } else if (extension == ".ply") {
    contents = AsciiPly(mesh);
  } else {
    return core::Status::InvalidArgument(path + ": unsupported mesh format '" + extension +
                                         "' (expected .stl, .obj, .ply or .off)");
  }
  return core::WriteFileAtomically(path, contents);
}

namespace {

MeshCheck CheckMeshUncached(const TriangleMesh& mesh) {
  MeshCheck check;
  if (mesh.triangles.empty()) {
    check.problem = "mesh has no triangles";
    return check;
  }
  check.problem = IndexProblem(mesh);
  if (!check.problem.empty()) return check;
  for (size_t v = 0; v < mesh.vertices.size(); ++v) {
    if (!mesh.vertices[v].allFinite()) {
      check.problem = "vertex " + std::to_string(v) + " is not finite (NaN or infinity)";
      return check;
    }
  }

  InexactMesh surface;
  if (!ToSurfaceMesh(mesh, &surface)) {
    check.problem =
        "not a manifold surface (an edge with more than two triangles, two triangles "
        "traversing an edge the same way, or a pinched vertex); self-intersection not checked";
    return check;
  }
  check.closed = CGAL::is_closed(surface);
  size_t degenerate_faces = 0;
  for (auto f : surface.faces()) {
    if (PMP::is_degenerate_triangle_face(f, surface)) ++degenerate_faces;
  }
  // CGAL reports a degenerate triangle as intersecting itself.
  check.self_intersecting = PMP::does_self_intersect(surface);
  if (check.closed && !check.self_intersecting) {
    // does_bound_a_volume accepts nested components only when their
    // orientations alternate; a consistently inverted mesh bounds a volume
    // too, just with its faces inward, which `outward` reports.
    bool bounds = PMP::does_bound_a_volume(surface);
    if (!bounds) {
      InexactMesh reversed = surface;
      PMP::reverse_face_orientations(reversed);
      bounds = PMP::does_bound_a_volume(reversed);
    }
    check.bounds_volume = bounds;
    check.outward = bounds && SignedVolume(mesh) > 0.0;
  }

  std::vector<std::string> problems;
  if (!check.closed) problems.push_back("not closed (some edges have only one triangle)");
  if (degenerate_faces > 0) {
    problems.push_back(std::to_string(degenerate_faces) + " degenerate (zero-area) triangles");
  }
  if (check.self_intersecting) problems.push_back("self-intersecting");
  if (check.closed && !check.self_intersecting && !check.bounds_volume) {
    problems.push_back("components are not oriented consistently, so it bounds no volume");
  }
  if (check.bounds_volume && !check.outward) problems.push_back("triangles face inward");
  for (size_t i = 0; i < problems.size(); ++i) {
    check.problem += (i == 0 ? "" : "; ") + problems[i];
  }
  return check;
}

// Vec3 and Eigen::Vector3i are plain arrays, so a mesh's arrays are its
// exact bytes.
static_assert(sizeof(Vec3) == 3 * sizeof(double) && sizeof(Eigen::Vector3i) == 3 * sizeof(int));

// A hash of the mesh's exact bytes, to find it in the memo.
uint64_t MeshFingerprint(const TriangleMesh& mesh) {
  const uint64_t vertices = core::FastHash64(mesh.vertices.data(), mesh.vertices.size() * sizeof(Vec3));
  return core::FastHash64(mesh.triangles.data(), mesh.triangles.size() * sizeof(Eigen::Vector3i), vertices);
}

bool SameMesh(const TriangleMesh& a, const TriangleMesh& b) {
  return a.vertices.size() == b.vertices.size() && a.triangles.size() == b.triangles.size() &&
         std::memcmp(a.vertices.data(), b.vertices.data(), a.vertices.size() * sizeof(Vec3)) == 0 &&
         std::memcmp(a.triangles.data(), b.triangles.data(), a.triangles.size() * sizeof(Eigen::Vector3i)) == 0;
}

// The meshes checked most recently, kept whole: a hit must be the same mesh
// to the last bit, not only the same hash, so a memo can never vouch for a
// mesh it has not checked.
struct CheckedMesh {
  uint64_t fingerprint;
  TriangleMesh mesh;
  MeshCheck check;
};
// Meshes; a CAD export's small shells (bolts, washers) are many. Smaller
// meshes than kCheckMemoMinTriangles are kept only when the repaired-mesh
// cache vouches for them (checking them again costs little, but a robot may
// have hundreds).
constexpr size_t kCheckMemoSize = 1024;
constexpr size_t kCheckMemoMinTriangles = 1000;
std::mutex check_memo_mutex;
std::vector<CheckedMesh> check_memo;  // most recent last

void RememberCheck(uint64_t fingerprint, const TriangleMesh& mesh, const MeshCheck& check) {
  const std::lock_guard<std::mutex> lock(check_memo_mutex);
  for (const CheckedMesh& entry : check_memo) {
    if (entry.fingerprint == fingerprint && SameMesh(entry.mesh, mesh)) return;
  }
  if (check_memo.size() >= kCheckMemoSize) check_memo.erase(check_memo.begin());
  check_memo.push_back({fingerprint, mesh, check});
}

}  // namespace

// The same mesh is checked by its repair, by quadhand-sdfgen's early check,
// by the SDF generator and by every signed distance query built on it; the
// self-intersection test is the costly part (seconds for 400,000 triangles),
// so it runs once per mesh and process.
MeshCheck CheckMesh(const TriangleMesh& mesh) {
  const uint64_t fingerprint = MeshFingerprint(mesh);
  {
    const std::lock_guard<std::mutex> lock(check_memo_mutex);
    for (const CheckedMesh& entry : check_memo) {
      if (entry.fingerprint == fingerprint && SameMesh(entry.mesh, mesh)) return entry.check;
    }
  }
  MeshCheck check = CheckMeshUncached(mesh);
  if (mesh.triangles.size() >= kCheckMemoMinTriangles) RememberCheck(fingerprint, mesh, check);
  return check;
}

void RememberMeshBoundsVolume(const TriangleMesh& mesh) {
  MeshCheck check;
  check.closed = true;
  check.bounds_volume = true;
  check.outward = true;
  RememberCheck(MeshFingerprint(mesh), mesh, check);
}

core::Result<TriangleMesh> UnionOfClosedMeshes(const std::vector<TriangleMesh>& parts) {
  if (parts.empty()) return core::Status::InvalidArgument("union of no meshes");
  std::vector<ExactMesh> exact_parts(parts.size());
  for (size_t i = 0; i < parts.size(); ++i) {
    const MeshCheck check = CheckMesh(parts[i]);
    if (!check.outward) {
      return core::Status::InvalidArgument("union: part " + std::to_string(i) +
                                           " does not bound a volume with outward triangles: " +
                                           check.problem);
    }
    ToSurfaceMesh(parts[i], &exact_parts[i]);
  }
  ExactMesh accumulated = std::move(exact_parts[0]);
  for (size_t i = 1; i < exact_parts.size(); ++i) {
    ExactMesh merged;
    bool ok = false;
    try {
      // Corefinement modifies both inputs (it inserts their intersection curves).
      ok = PMP::corefine_and_compute_union(accumulated, exact_parts[i], merged);
    } catch (const std::exception& e) {
      return core::Status::Internal("union: CGAL failed on part " + std::to_string(i) + ": " +
                                    e.what());
    }
    if (!ok) {
      return core::Status::Internal("union: the union with part " + std::to_string(i) +
                                    " is not a manifold surface");
    }
    accumulated = std::move(merged);
  }
  TriangleMesh result = CanonicalOrder(FromSurfaceMesh(accumulated));
  // Rounding exact intersection points to doubles can in principle create
  // tiny self-intersections: verify instead of assuming.
  const MeshCheck check = CheckMesh(result);
  if (!check.outward) {
    return core::Status::Internal("union: the result rounded to double precision is invalid: " +
                                  check.problem);
  }
  return result;
}

}  // namespace quadhand::geometry
