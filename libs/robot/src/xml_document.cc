#include "xml_document.h"

#include <algorithm>
#include <cstddef>
#include <string>
#include <utility>

#include <tinyxml.h>

namespace quadhand::robot {

namespace {

// `xml` with its comments and CDATA sections blanked out, so that markup
// quoted in them ("<!-- no <!ENTITY here -->") is not taken for the real
// thing. An unterminated one blanks the rest (the parse then reports it).
std::string WithoutCommentsAndCdata(std::string xml) {
  const std::pair<const char*, const char*> spans[] = {{"<!--", "-->"}, {"<![CDATA[", "]]>"}};
  size_t at = 0;
  while (true) {
    size_t begin = std::string::npos;
    const char* open_mark = nullptr;
    const char* end_mark = nullptr;
    for (const auto& [open, close] : spans) {
      const size_t found = xml.find(open, at);
      if (found < begin) {
        begin = found;
        open_mark = open;
        end_mark = close;
      }
    }
    if (begin == std::string::npos) return xml;
    const size_t close = xml.find(end_mark, begin + std::char_traits<char>::length(open_mark));
    const size_t end = close == std::string::npos ? xml.size() : close + std::char_traits<char>::length(end_mark);
    std::fill(xml.begin() + static_cast<std::ptrdiff_t>(begin), xml.begin() + static_cast<std::ptrdiff_t>(end), ' ');
    at = end;
  }
}

// Whether the <!DOCTYPE at `doctype` has an internal subset ("[" before its
// closing ">", outside the quoted system and public ids).
bool HasInternalSubset(const std::string& xml, size_t doctype) {
  char quote = 0;
  for (size_t i = doctype; i < xml.size(); ++i) {
    const char c = xml[i];
    if (quote != 0) {
      if (c == quote) quote = 0;
    } else if (c == '"' || c == '\'') {
      quote = c;
    } else if (c == '[') {
      return true;
    } else if (c == '>') {
      return false;
    }
  }
  return false;
}

}  // namespace

std::string ParseXmlDocument(const std::string& xml, TiXmlDocument* doc) {
  if (xml.find_first_not_of(" \t\r\n") == std::string::npos) return "empty document";
  const std::string markup = WithoutCommentsAndCdata(xml);
  const bool entity = markup.find("<!ENTITY") != std::string::npos;
  const size_t doctype = markup.find("<!DOCTYPE");
  const bool subset = doctype != std::string::npos && HasInternalSubset(markup, doctype);
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
