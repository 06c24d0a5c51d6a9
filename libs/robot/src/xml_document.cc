#include "xml_document.h"

#include <tinyxml.h>

namespace quadhand::robot {

std::string ParseXmlDocument(const std::string& xml, TiXmlDocument* doc) {
  if (xml.find_first_not_of(" \t\r\n") == std::string::npos) return "empty document";
  const bool entity = xml.find("<!ENTITY") != std::string::npos;
  const size_t doctype = xml.find("<!DOCTYPE");
  bool subset = false;
  if (doctype != std::string::npos) {
    const size_t bracket = xml.find('[', doctype), close = xml.find('>', doctype);
    subset = bracket != std::string::npos && (close == std::string::npos || bracket < close);
  }
  if (entity || subset) {
    return "the document declares a document type definition (<!DOCTYPE ... [ ... ]> or <!ENTITY>), which URDF "
           "and SRDF do not use and which is not read (entities are not expanded): remove it";
  }
  doc->Parse(xml.c_str());
  if (doc->Error()) {
    // tinyxml's descriptions are fixed one-line sentences.
    return "malformed XML at line " + std::to_string(doc->ErrorRow()) + ", column " +
           std::to_string(doc->ErrorCol()) + ": " + doc->ErrorDesc();
  }
  return "";
}

}  // namespace quadhand::robot
