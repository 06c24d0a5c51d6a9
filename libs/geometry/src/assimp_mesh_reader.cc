#include "assimp_mesh_reader.h"

#include <assimp/Importer.hpp>
#include <assimp/config.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>

#include "quadhand/core/isolated.h"

namespace quadhand::geometry {
namespace {

// Assimp's Collada importer trusts index lists and counts: a '=' in a <p>
// list made it allocate 2.4 GB for a 1.7 KB file (found by fuzzing). The
// text is checked first: index lists (<p>, <v>, <vcount>, <h>, <int_array>)
// hold whole numbers only, every array and accessor has a count, and no
// count="N" exceeds the file's size (every element takes at least a byte).
std::string ColladaTextProblem(const std::string& text) {
  for (const char* tag : {"p", "v", "vcount", "h", "int_array"}) {
    const std::string open = std::string("<") + tag, close = std::string("</") + tag + ">";
    for (std::size_t at = text.find(open); at != std::string::npos; at = text.find(open, at + 1)) {
      const std::size_t after = at + open.size();
      if (after >= text.size() || (text[after] != '>' && text[after] != ' ' && text[after] != '\t' &&
                                   text[after] != '\n' && text[after] != '\r')) {
        continue;  // another tag sharing the prefix (<polylist>, <vertices>)
      }
      const std::size_t begin = text.find('>', after);
      if (begin == std::string::npos) return std::string("unterminated <") + tag + ">";
      if (text[begin - 1] == '/') continue;  // <p/>
      const std::size_t end = text.find(close, begin);
      if (end == std::string::npos) return std::string("<") + tag + "> without " + close;
      for (std::size_t i = begin + 1; i < end; ++i) {
        const char c = text[i];
        if (!(c >= '0' && c <= '9') && c != ' ' && c != '\t' && c != '\n' && c != '\r' && c != '-') {
          return std::string("<") + tag + "> holds something that is not a whole number";
        }
      }
    }
  }
  // Every array says how many values it holds (without it Assimp read
  // through a null pointer; found by fuzzing).
  for (const char* tag : {"<float_array", "<int_array", "<accessor"}) {
    for (std::size_t at = text.find(tag); at != std::string::npos; at = text.find(tag, at + 1)) {
      const std::size_t end = text.find('>', at);
      if (end == std::string::npos) return std::string("unterminated ") + tag + ">";
      const std::string element = text.substr(at, end - at);
      if (element.find(" count=\"") == std::string::npos && element.find("\tcount=\"") == std::string::npos &&
          element.find("\ncount=\"") == std::string::npos) {
        return std::string(tag + 1) + " without a count";
      }
    }
  }
  for (std::size_t at = text.find("count=\""); at != std::string::npos; at = text.find("count=\"", at + 1)) {
    const std::size_t begin = at + 7, end = text.find('"', begin);
    if (end == std::string::npos || end - begin > 19) return "a count attribute that is not a number";
    const std::string digits = text.substr(begin, end - begin);
    if (digits.empty() || digits.find_first_not_of("0123456789") != std::string::npos) {
      return "a count attribute that is not a whole number";
    }
    if (std::stoull(digits) > text.size()) return "a count larger than the file could hold";
  }
  return "";
}

}  // namespace

namespace {

core::Result<TriangleSoup> ImportSoup(const std::string& path) {
  Assimp::Importer importer;
  importer.SetPropertyBool(AI_CONFIG_IMPORT_COLLADA_IGNORE_UP_DIRECTION, true);
  // Points and lines are not surfaces: drop them rather than fail.
  importer.SetPropertyInteger(AI_CONFIG_PP_SBP_REMOVE, aiPrimitiveType_POINT | aiPrimitiveType_LINE);
  const aiScene* scene =
      importer.ReadFile(path, aiProcess_Triangulate | aiProcess_JoinIdenticalVertices | aiProcess_SortByPType |
                                  aiProcess_PreTransformVertices);
  if (scene == nullptr) {
    return core::Status::InvalidArgument(path + ": cannot read mesh (" + importer.GetErrorString() + ")");
  }
  TriangleSoup soup;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh* mesh = scene->mMeshes[m];
    const std::size_t offset = soup.vertices.size();
    for (unsigned v = 0; v < mesh->mNumVertices; ++v) {
      const aiVector3D& p = mesh->mVertices[v];
      soup.vertices.emplace_back(p.x, p.y, p.z);
    }
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const aiFace& face = mesh->mFaces[f];
      if (face.mNumIndices != 3) continue;
      soup.triangles.push_back({offset + face.mIndices[0], offset + face.mIndices[1], offset + face.mIndices[2]});
    }
  }
  return soup;
}

// The soup as bytes for the trip out of the child process and back: the
// counts, then the vertices' doubles and the triangles' indices.
std::string Serialize(const TriangleSoup& soup) {
  const std::uint64_t counts[2] = {soup.vertices.size(), soup.triangles.size()};
  std::string bytes(reinterpret_cast<const char*>(counts), sizeof(counts));
  for (const Vec3& v : soup.vertices) bytes.append(reinterpret_cast<const char*>(v.data()), 3 * sizeof(double));
  for (const auto& t : soup.triangles) {
    const std::uint64_t indices[3] = {t[0], t[1], t[2]};
    bytes.append(reinterpret_cast<const char*>(indices), sizeof(indices));
  }
  return bytes;
}

core::Result<TriangleSoup> Deserialize(const std::string& bytes, const std::string& path) {
  std::uint64_t counts[2] = {0, 0};
  if (bytes.size() < sizeof(counts)) return core::Status::Internal(path + ": the mesh reader returned too little");
  std::memcpy(counts, bytes.data(), sizeof(counts));
  const long double expected = sizeof(counts) + static_cast<long double>(counts[0]) * 3 * sizeof(double) +
                               static_cast<long double>(counts[1]) * 3 * sizeof(std::uint64_t);
  if (expected != static_cast<long double>(bytes.size())) {
    return core::Status::Internal(path + ": the mesh reader returned a result of the wrong size");
  }
  TriangleSoup soup;
  soup.vertices.resize(counts[0]);
  soup.triangles.resize(counts[1]);
  const char* at = bytes.data() + sizeof(counts);
  for (Vec3& v : soup.vertices) {
    std::memcpy(v.data(), at, 3 * sizeof(double));
    at += 3 * sizeof(double);
  }
  for (auto& t : soup.triangles) {
    std::uint64_t indices[3];
    std::memcpy(indices, at, sizeof(indices));
    at += sizeof(indices);
    t = {indices[0], indices[1], indices[2]};
  }
  return soup;
}

}  // namespace

core::Result<TriangleSoup> ReadAssimpSoup(const std::string& path) {
  {
    std::ifstream in(path, std::ios::binary);
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (const std::string problem = ColladaTextProblem(text); !problem.empty()) {
      return core::Status::InvalidArgument(path + ": cannot read mesh (" + problem + ")");
    }
  }
#ifdef QUADHAND_ASSIMP_IN_PROCESS
  // Fuzzing builds import in process, so that the fuzzer sees Assimp's code.
  return ImportSoup(path);
#else
  // Assimp's importers have crashed, hung and allocated gigabytes on
  // malformed files (docs/reliability.md): the import runs in a child process
  // with a memory and time limit, so whatever it does is an error here.
  auto bytes = core::RunIsolated(
      [&path]() -> core::Result<std::string> {
        auto soup = ImportSoup(path);
        if (!soup.ok()) return soup.status();
        return Serialize(*soup);
      },
      path + ": cannot read mesh: the Collada importer");
  if (!bytes.ok()) return bytes.status();
  return Deserialize(*bytes, path);
#endif
}

}  // namespace quadhand::geometry
