#include "quadhand/core/yaml_text.h"

#include <map>

#include <yaml-cpp/yaml.h>

namespace quadhand::core {
namespace {

constexpr int kMaxDepth = 64;
// Nodes visited, aliases counted at every use: no configuration comes near
// it, and it stops an alias bomb (nine aliases of nine aliases ... expand to
// billions of nodes from a few hundred bytes) before any reader walks it.
constexpr long kMaxNodes = 100000;

std::string Line(const YAML::Mark& mark) { return "line " + std::to_string(mark.line + 1); }

Status CheckNode(const YAML::Node& node, const std::string& name, int depth, long* nodes) {
  if (++*nodes > kMaxNodes) {
    return Status::InvalidArgument(name + ": " + Line(node.Mark()) + ": more than " + std::to_string(kMaxNodes) +
                                   " nodes (counting every use of an alias)");
  }
  if (depth > kMaxDepth) {
    return Status::InvalidArgument(name + ": " + Line(node.Mark()) + ": nested more than " +
                                   std::to_string(kMaxDepth) + " levels deep");
  }
  if (node.IsMap()) {
    std::map<std::string, YAML::Mark> seen;
    for (auto it = node.begin(); it != node.end(); ++it) {
      if (it->first.IsScalar()) {
        const auto [where, inserted] = seen.emplace(it->first.Scalar(), it->first.Mark());
        if (!inserted) {
          return Status::InvalidArgument(name + ": " + Line(it->first.Mark()) + ": duplicate key '" +
                                         it->first.Scalar() + "' (first on " + Line(where->second) + ")");
        }
      }
      QUADHAND_RETURN_IF_ERROR(CheckNode(it->second, name, depth + 1, nodes));
    }
  } else if (node.IsSequence()) {
    for (const YAML::Node& item : node) QUADHAND_RETURN_IF_ERROR(CheckNode(item, name, depth + 1, nodes));
  }
  return Status::Ok();
}

}  // namespace

Status CheckYamlText(const std::string& text, const std::string& name) {
  try {
    long nodes = 0;
    return CheckNode(YAML::Load(text), name, 0, &nodes);
  } catch (const YAML::Exception& e) {
    return Status::InvalidArgument(name + ": not valid YAML: " + Line(e.mark) + ": " + e.msg);
  }
}

}  // namespace quadhand::core
