#include "quadhand/viz/html_view.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <numeric>
#include <random>
#include <string_view>

#include "embedded_assets.h"
#include "quadhand/core/file_util.h"

namespace quadhand::viz {
namespace {

// Version of the data block the page script reads.
constexpr int kDataVersion = 1;
// Coordinates are stored relative to an origin only when the scene is this far
// from the world origin (Float32 keeps about 1e-5 m at 100 m).
constexpr double kFarFromOrigin = 1000.0;
// Seed of the cloud subsampling, so equal inputs give equal pages.
constexpr std::uint32_t kSubsampleSeed = 20240611u;

std::string Base64(const std::string& bytes) {
  static const char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const std::uint32_t v = (std::uint32_t(std::uint8_t(bytes[i])) << 16) |
                            (std::uint32_t(std::uint8_t(bytes[i + 1])) << 8) |
                            std::uint32_t(std::uint8_t(bytes[i + 2]));
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += kAlphabet[v & 63];
  }
  if (i + 1 == bytes.size()) {
    const std::uint32_t v = std::uint32_t(std::uint8_t(bytes[i])) << 16;
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += "==";
  } else if (i + 2 == bytes.size()) {
    const std::uint32_t v = (std::uint32_t(std::uint8_t(bytes[i])) << 16) |
                            (std::uint32_t(std::uint8_t(bytes[i + 1])) << 8);
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += '=';
  }
  return out;
}

// Little-endian binary arrays, whatever the host byte order.
class LittleEndianWriter {
 public:
  void U32(std::uint32_t v) {
    for (int b = 0; b < 4; ++b) bytes_ += static_cast<char>((v >> (8 * b)) & 0xFF);
  }
  void F32(double value) {
    const float f = static_cast<float>(value);
    std::uint32_t v;
    std::memcpy(&v, &f, sizeof v);
    U32(v);
  }
  void F64(double value) {
    std::uint64_t v;
    std::memcpy(&v, &value, sizeof v);
    for (int b = 0; b < 8; ++b) bytes_ += static_cast<char>((v >> (8 * b)) & 0xFF);
  }
  void Vec(const Vec3& p) { F32(p.x()); F32(p.y()); F32(p.z()); }
  void Reserve(std::size_t n) { bytes_.reserve(n); }
  std::string Base64() const { return viz::Base64(bytes_); }

 private:
  std::string bytes_;
};

// A JSON string literal that is also safe inside a <script> element.
std::string JsonString(const std::string& text) {
  std::string out = "\"";
  for (const char ch : text) {
    const unsigned char c = static_cast<unsigned char>(ch);
    switch (ch) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\r': out += "\\r"; break;
      case '\t': out += "\\t"; break;
      case '<': out += "\\u003c"; break;
      case '>': out += "\\u003e"; break;
      case '&': out += "\\u0026"; break;
      default:
        if (c < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\u%04x", c);
          out += buf;
        } else {
          out += ch;
        }
    }
  }
  out += '"';
  return out;
}

std::string HtmlEscape(const std::string& text) {
  std::string out;
  for (const char ch : text) {
    switch (ch) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\n': case '\r': case '\t': out += ' '; break;
      default: out += ch;
    }
  }
  return out;
}

std::string Number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

bool Finite(const Vec3& v) { return v.allFinite(); }

std::string Where(const char* what, std::size_t i) {
  return std::string(what) + " " + std::to_string(i);
}

core::Status Validate(const HtmlViewData& data) {
  if (data.link_poses.size() != data.times.size()) {
    return core::Status::InvalidArgument("html view: " + std::to_string(data.link_poses.size()) +
                                         " pose rows for " + std::to_string(data.times.size()) +
                                         " times");
  }
  for (std::size_t i = 0; i < data.times.size(); ++i) {
    if (!std::isfinite(data.times[i])) {
      return core::Status::InvalidArgument("html view: " + Where("time", i) + " is not finite");
    }
    if (i > 0 && data.times[i] < data.times[i - 1]) {
      return core::Status::InvalidArgument("html view: times decrease at " + Where("sample", i));
    }
    if (data.link_poses[i].size() != data.links.size()) {
      return core::Status::InvalidArgument(
          "html view: " + Where("sample", i) + " has " + std::to_string(data.link_poses[i].size()) +
          " link poses for " + std::to_string(data.links.size()) + " links");
    }
    for (const Pose& pose : data.link_poses[i]) {
      if (!pose.matrix().allFinite()) {
        return core::Status::InvalidArgument("html view: a link pose at " + Where("sample", i) +
                                             " is not finite");
      }
    }
  }
  for (const auto& link : data.links) {
    const int n = static_cast<int>(link.mesh_in_link_frame.vertices.size());
    for (const Vec3& v : link.mesh_in_link_frame.vertices) {
      if (!Finite(v)) {
        return core::Status::InvalidArgument("html view: link " + link.name +
                                             " has a non-finite vertex");
      }
    }
    for (const Eigen::Vector3i& t : link.mesh_in_link_frame.triangles) {
      if ((t.array() < 0).any() || (t.array() >= n).any()) {
        return core::Status::InvalidArgument("html view: link " + link.name +
                                             " has a triangle index out of range");
      }
    }
  }
  for (const auto* path : {&data.base_path, &data.tool_path}) {
    for (const Vec3& p : *path) {
      if (!Finite(p)) {
        return core::Status::InvalidArgument(
            std::string("html view: the ") + (path == &data.base_path ? "base" : "tool") +
            " path has a non-finite point");
      }
    }
  }
  if (data.has_insertion && (!Finite(data.insertion_start) || !Finite(data.insertion_end))) {
    return core::Status::InvalidArgument("html view: the insertion line is not finite");
  }
  if (!data.moving_points.empty()) {
    if (data.moving_displacements.size() != data.times.size()) {
      return core::Status::InvalidArgument("html view: " + std::to_string(data.moving_displacements.size()) +
                                           " moving-point displacements for " + std::to_string(data.times.size()) +
                                           " times");
    }
    for (const Pose& pose : data.moving_displacements) {
      if (!pose.matrix().allFinite()) {
        return core::Status::InvalidArgument("html view: a moving-point displacement is not finite");
      }
    }
  }
  return core::Status::Ok();
}

// Indices of the finite points, a fixed-seed uniform subset when over the cap,
// in their original order.
std::vector<std::size_t> SelectPoints(const std::vector<Vec3>& points, int max_points) {
  std::vector<std::size_t> finite;
  finite.reserve(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (Finite(points[i])) finite.push_back(i);
  }
  const std::size_t cap = static_cast<std::size_t>(std::max(0, max_points));
  if (finite.size() <= cap) return finite;
  std::mt19937 rng(kSubsampleSeed);
  for (std::size_t i = 0; i < cap; ++i) {  // partial Fisher-Yates
    std::uniform_int_distribution<std::size_t> pick(i, finite.size() - 1);
    std::swap(finite[i], finite[pick(rng)]);
  }
  finite.resize(cap);
  std::sort(finite.begin(), finite.end());
  return finite;
}

std::string PathArray(const std::vector<Vec3>& path, int max_points, const Vec3& origin) {
  LittleEndianWriter w;
  const std::size_t n = path.size();
  const std::size_t cap = static_cast<std::size_t>(std::max(2, max_points));
  const std::size_t stride = n > cap ? (n + cap - 2) / (cap - 1) : 1;
  for (std::size_t i = 0; i < n; i += stride) w.Vec(path[i] - origin);
  if (n > 0 && (n - 1) % stride != 0) w.Vec(path[n - 1] - origin);
  return w.Base64();
}

// Origin the page stores coordinates against: zero unless the data lies far
// from the world origin, then the whole-metre centre of its bounds.
Vec3 StorageOrigin(const HtmlViewData& data) {
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity());
  Vec3 hi = -lo;
  auto add = [&](const Vec3& p) {
    if (!Finite(p)) return;
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  };
  for (const Vec3& p : data.points) add(p);
  for (const Vec3& p : data.base_path) add(p);
  for (const Vec3& p : data.tool_path) add(p);
  for (const auto& row : data.link_poses) {
    for (const Pose& pose : row) add(pose.translation());
  }
  if (!(lo.array() <= hi.array()).all()) return Vec3::Zero();
  if (std::max(lo.cwiseAbs().maxCoeff(), hi.cwiseAbs().maxCoeff()) < kFarFromOrigin) {
    return Vec3::Zero();
  }
  return (0.5 * (lo + hi)).array().round().matrix();
}

// One sample of a pose track: the translation, then the rotation as
// x, y, z, w in the hemisphere of the track's last sample (`previous`), so
// that the page's slerp between samples takes the short way.
void WritePose(const Vec3& translation, const Mat3& rotation, Eigen::Vector4d* previous, LittleEndianWriter* out) {
  Quat q(rotation);
  q.normalize();
  Eigen::Vector4d xyzw(q.x(), q.y(), q.z(), q.w());
  if (xyzw.dot(*previous) < 0.0) xyzw = -xyzw;
  *previous = xyzw;
  out->Vec(translation);
  for (int k = 0; k < 4; ++k) out->F32(xyzw[k]);
}

std::string DataJson(const HtmlViewData& data, const HtmlViewOptions& options) {
  const Vec3 origin = StorageOrigin(data);
  std::string json = "{\"version\":" + std::to_string(kDataVersion);
  json += ",\"title\":" + JsonString(data.title);
  json += ",\"summary\":" + JsonString(data.summary);
  json += ",\"origin\":[" + Number(origin.x()) + "," + Number(origin.y()) + "," +
          Number(origin.z()) + "]";
  json += ",\"num_ghosts\":" + std::to_string(options.num_ghosts);

  const std::vector<std::size_t> selected = SelectPoints(data.points, options.max_points);
  std::size_t finite = 0;
  for (const Vec3& p : data.points) finite += Finite(p) ? 1 : 0;
  {
    LittleEndianWriter w;
    w.Reserve(selected.size() * 12);
    for (const std::size_t i : selected) w.Vec(data.points[i] - origin);
    json += ",\"points\":{\"count\":" + std::to_string(selected.size()) +
            ",\"total\":" + std::to_string(finite) + ",\"positions\":\"" + w.Base64() + "\"}";
  }

  json += ",\"links\":[";
  for (std::size_t j = 0; j < data.links.size(); ++j) {
    const geometry::TriangleMesh& mesh = data.links[j].mesh_in_link_frame;
    LittleEndianWriter vertices, triangles;
    for (const Vec3& v : mesh.vertices) vertices.Vec(v);
    for (const Eigen::Vector3i& t : mesh.triangles) {
      for (int k = 0; k < 3; ++k) triangles.U32(static_cast<std::uint32_t>(t[k]));
    }
    if (j > 0) json += ",";
    json += "{\"name\":" + JsonString(data.links[j].name) + ",\"vertices\":\"" +
            vertices.Base64() + "\",\"triangles\":\"" + triangles.Base64() + "\"}";
  }
  json += "]";

  {
    LittleEndianWriter times, poses;
    std::vector<Eigen::Vector4d> previous(data.links.size(), Eigen::Vector4d::Zero());
    for (std::size_t i = 0; i < data.times.size(); ++i) {
      times.F64(data.times[i]);
      for (std::size_t j = 0; j < data.links.size(); ++j) {
        const Pose& pose = data.link_poses[i][j];
        WritePose(pose.translation() - origin, pose.linear(), &previous[j], &poses);
      }
    }
    json += ",\"num_times\":" + std::to_string(data.times.size());
    json += ",\"times\":\"" + times.Base64() + "\",\"poses\":\"" + poses.Base64() + "\"";
  }

  // Moving points relative to the storage origin o: a displacement x ->
  // R x + p is, on x - o, (x - o) -> R (x - o) + (R o + p - o).
  const std::vector<std::size_t> moving = SelectPoints(data.moving_points, options.max_points);
  if (!moving.empty()) {
    LittleEndianWriter positions, poses;
    for (const std::size_t i : moving) positions.Vec(data.moving_points[i] - origin);
    Eigen::Vector4d previous = Eigen::Vector4d::Zero();
    for (const Pose& pose : data.moving_displacements) {
      WritePose(pose.linear() * origin + pose.translation() - origin, pose.linear(), &previous, &poses);
    }
    json += ",\"moving\":{\"count\":" + std::to_string(moving.size()) + ",\"positions\":\"" +
            positions.Base64() + "\",\"poses\":\"" + poses.Base64() + "\"}";
  } else {
    json += ",\"moving\":null";
  }

  json += ",\"base_path\":\"" + PathArray(data.base_path, options.max_path_points, origin) + "\"";
  json += ",\"tool_path\":\"" + PathArray(data.tool_path, options.max_path_points, origin) + "\"";
  if (data.has_insertion) {
    const Vec3 a = data.insertion_start - origin, b = data.insertion_end - origin;
    json += ",\"insertion\":[" + Number(a.x()) + "," + Number(a.y()) + "," + Number(a.z()) + "," +
            Number(b.x()) + "," + Number(b.y()) + "," + Number(b.z()) + "]";
  } else {
    json += ",\"insertion\":null";
  }
  json += "}";
  return json;
}

std::string ImportMapJson() {
  const std::string prefix = "data:text/javascript;base64,";
  return "{\"imports\":{\"three\":\"" + prefix +
         Base64(std::string(internal::ThreeModuleSource())) +
         "\",\"three/addons/controls/OrbitControls.js\":\"" + prefix +
         Base64(std::string(internal::OrbitControlsSource())) + "\"}}";
}

}  // namespace

bool HtmlViewOptions::IsValid(std::string* why) const {
  auto fail = [why](const char* message) {
    if (why) *why = message;
    return false;
  };
  if (max_points < 0) return fail("max_points must be >= 0");
  if (num_ghosts < 0 || num_ghosts > 100) return fail("num_ghosts must be in [0, 100]");
  if (max_path_points < 2) return fail("max_path_points must be >= 2");
  return true;
}

core::Result<std::string> RenderHtmlView(const HtmlViewData& data, const HtmlViewOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) return core::Status::InvalidArgument("html view options: " + why);
  QUADHAND_RETURN_IF_ERROR(Validate(data));

  const std::string title = data.title.empty() ? "QuadHand plan" : data.title;
  const std::string_view page = internal::PageTemplate();
  struct Slot {
    std::string_view key;
    std::string value;
  };
  const Slot slots[] = {
      {"@@TITLE@@", HtmlEscape(title)},
      {"@@THREE_VERSION@@", internal::ThreeVersion()},
      {"@@IMPORTMAP@@", ImportMapJson()},
      {"@@DATA@@", DataJson(data, options)},
  };
  // One pass over the template, so no inserted text is scanned again.
  std::string html;
  std::size_t reserve = page.size();
  for (const Slot& slot : slots) reserve += slot.value.size();
  html.reserve(reserve);
  std::size_t pos = 0;
  while (pos < page.size()) {
    const std::size_t at = page.find("@@", pos);
    if (at == std::string_view::npos) break;
    const Slot* hit = nullptr;
    for (const Slot& slot : slots) {
      if (page.compare(at, slot.key.size(), slot.key) == 0) hit = &slot;
    }
    if (hit == nullptr) {
      html.append(page.substr(pos, at + 2 - pos));
      pos = at + 2;
      continue;
    }
    html.append(page.substr(pos, at - pos));
    html += hit->value;
    pos = at + hit->key.size();
  }
  html.append(page.substr(pos));
  return html;
}

core::Status WriteHtmlView(const std::string& path, const HtmlViewData& data,
                           const HtmlViewOptions& options) {
  core::Result<std::string> html = RenderHtmlView(data, options);
  if (!html.ok()) return html.status().WithPrefix(path);
  return core::WriteFileAtomically(path, *html);
}

const char* EmbeddedThreeVersion() { return internal::ThreeVersion(); }

}  // namespace quadhand::viz
