// The XML pass the URDF and SRDF readers share (tinyxml, the reader urdfdom
// uses): one place for what tinyxml cannot be trusted with and for how a
// malformed document is reported.
#pragma once

#include <string>

class TiXmlDocument;

namespace quadhand::robot {

// Parses `xml` into `doc`; returns the problem ("" when it parsed): an
// empty document, a document type definition, or malformed XML with its
// line and column. tinyxml reads no document type definition: a DOCTYPE
// with an internal subset ends at its first '>', the rest of the document is
// misread (a <robot> after it is not found), and entities are never
// expanded. URDF and SRDF do not use them, so a document that declares them
// is refused by name instead of failing later with a misleading error.
std::string ParseXmlDocument(const std::string& xml, TiXmlDocument* doc);

}  // namespace quadhand::robot
