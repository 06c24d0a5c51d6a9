// What the URDF and SRDF readers share about XML: tinyxml, the reader
// urdfdom uses, does not read document type definitions. A DOCTYPE with an
// internal subset ends at its first '>', the rest of the document is
// misread (a <robot> after it is not found), and entities are never
// expanded. URDF and SRDF do not use them, so a document that declares them
// is refused by name instead of failing later with a misleading error.
#pragma once

#include <string>

namespace quadhand::robot {

// The problem with `xml`'s document type declaration, or "" when it has none
// that tinyxml would misread.
inline std::string DocumentTypeProblem(const std::string& xml) {
  const bool entity = xml.find("<!ENTITY") != std::string::npos;
  const size_t doctype = xml.find("<!DOCTYPE");
  bool subset = false;
  if (doctype != std::string::npos) {
    const size_t bracket = xml.find('[', doctype), close = xml.find('>', doctype);
    subset = bracket != std::string::npos && (close == std::string::npos || bracket < close);
  }
  if (!entity && !subset) return "";
  return "the document declares a document type definition (<!DOCTYPE ... [ ... ]> or <!ENTITY>), which URDF and "
         "SRDF do not use and which is not read (entities are not expanded): remove it";
}

}  // namespace quadhand::robot
