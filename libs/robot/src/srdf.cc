#include "quadhand/robot/srdf.h"

#include <algorithm>

#include <tinyxml.h>

#include "quadhand/core/file_util.h"

#include "xml_document.h"

namespace quadhand::robot {

core::Result<std::vector<std::pair<int, int>>> LoadSrdfDisabledPairs(const std::string& path,
                                                                     const RobotModel& robot) {
  core::Result<std::string> xml = core::ReadFileToString(path);
  if (!xml.ok()) return xml.status();
  auto error = [&path](const std::string& what) { return core::Status::InvalidArgument(path + ": " + what); };
  TiXmlDocument doc;
  if (std::string problem = ParseXmlDocument(*xml, &doc); !problem.empty()) return error(problem);
  const TiXmlElement* root = doc.RootElement();
  if (root == nullptr || std::string(root->Value()) != "robot") return error("the root element is not <robot>");
  std::vector<std::pair<int, int>> pairs;
  for (const TiXmlElement* e = root->FirstChildElement("disable_collisions"); e != nullptr;
       e = e->NextSiblingElement("disable_collisions")) {
    const char* first = e->Attribute("link1");
    const char* second = e->Attribute("link2");
    if (first == nullptr || second == nullptr) {
      return error("<disable_collisions> on line " + std::to_string(e->Row()) + " needs link1 and link2");
    }
    int a = robot.LinkIndex(first), b = robot.LinkIndex(second);
    for (const auto& [name, index] : {std::pair<const char*, int>{first, a}, {second, b}}) {
      if (index < 0) {
        return error("<disable_collisions> on line " + std::to_string(e->Row()) + ": the robot has no link named '" +
                     name + "'");
      }
    }
    if (a == b) continue;
    if (a > b) std::swap(a, b);
    pairs.emplace_back(a, b);
  }
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  return pairs;
}

}  // namespace quadhand::robot
