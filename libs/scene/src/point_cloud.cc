#include "quadhand/scene/point_cloud.h"

#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include <pcl/PCLPointCloud2.h>
#include <pcl/console/print.h>
#include <pcl/conversions.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include "quadhand/core/file_util.h"
#include "quadhand/core/numbers.h"
#include "quadhand/core/ply_header.h"

namespace quadhand::scene {
namespace {

// Longest header read (PCD, PLY), and the longest data row beyond 64
// characters per value: lines are read with a limit, so a file without
// line breaks is refused after that much, not read whole.
constexpr std::size_t kMaxHeaderBytes = 65536;
constexpr std::size_t kMaxRowBytes = 65536;

// PCL prints its own diagnostics to the console; ours come back as Status.
void SilencePcl() { pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS); }

const pcl::PCLPointField* FindField(const pcl::PCLPointCloud2& cloud, const std::string& name) {
  for (const auto& field : cloud.fields) {
    if (field.name == name) return &field;
  }
  return nullptr;
}

// Bytes of one value of a PCL field datatype (0: unknown).
int DatatypeSize(std::uint8_t datatype) {
  switch (datatype) {
    case pcl::PCLPointField::INT8:
    case pcl::PCLPointField::UINT8: return 1;
    case pcl::PCLPointField::INT16:
    case pcl::PCLPointField::UINT16: return 2;
    case pcl::PCLPointField::INT32:
    case pcl::PCLPointField::UINT32:
    case pcl::PCLPointField::FLOAT32: return 4;
    case pcl::PCLPointField::FLOAT64: return 8;
    default: return 0;
  }
}

template <typename T>
double Read(const std::uint8_t* bytes) {
  T value;
  std::memcpy(&value, bytes, sizeof(T));
  return static_cast<double>(value);
}

double ReadValue(const std::uint8_t* bytes, std::uint8_t datatype) {
  switch (datatype) {
    case pcl::PCLPointField::INT8: return Read<std::int8_t>(bytes);
    case pcl::PCLPointField::UINT8: return Read<std::uint8_t>(bytes);
    case pcl::PCLPointField::INT16: return Read<std::int16_t>(bytes);
    case pcl::PCLPointField::UINT16: return Read<std::uint16_t>(bytes);
    case pcl::PCLPointField::INT32: return Read<std::int32_t>(bytes);
    case pcl::PCLPointField::UINT32: return Read<std::uint32_t>(bytes);
    case pcl::PCLPointField::FLOAT32: return Read<float>(bytes);
    default: return Read<double>(bytes);
  }
}

// The fields x, y, z must exist, hold one number each of a numeric type,
// and fit in a point; the error says which does not.
core::Status CheckCoordinateFields(const pcl::PCLPointCloud2& cloud, const std::string& path, const char* format) {
  for (const char* name : {"x", "y", "z"}) {
    const pcl::PCLPointField* field = FindField(cloud, name);
    if (field == nullptr) {
      return core::Status::InvalidArgument(path + ": not a " + format + " point cloud with x, y, z fields");
    }
    if (field->count != 1) {
      return core::Status::InvalidArgument(path + ": field " + name + " has COUNT " + std::to_string(field->count) +
                                           " (a coordinate must be one number)");
    }
    const int size = DatatypeSize(field->datatype);
    if (size == 0) return core::Status::InvalidArgument(path + ": field " + name + " has an unknown type");
    if (cloud.point_step > 0 && field->offset + size > cloud.point_step) {
      return core::Status::InvalidArgument(path + ": field " + name + " lies outside the point's bytes");
    }
  }
  return core::Status::Ok();
}

// Every point's x, y, z converted from its stored type (float32 or 64,
// signed or unsigned integers of 8 to 32 bits) to double; non-finite points
// dropped and counted.
core::Result<PointCloud> ExtractPoints(const pcl::PCLPointCloud2& cloud, const std::string& path, const char* format,
                                       EmptyCloud empty) {
  QUADHAND_RETURN_IF_ERROR(CheckCoordinateFields(cloud, path, format));
  const std::uint64_t count = static_cast<std::uint64_t>(cloud.width) * cloud.height;
  if (count == 0 && empty == EmptyCloud::kAllow) return PointCloud{};
  if (count == 0) return core::Status::InvalidArgument(path + ": point cloud has no finite points (it is empty)");
  const std::uint64_t row_bytes = static_cast<std::uint64_t>(cloud.width) * cloud.point_step;
  const std::uint64_t row_step = cloud.row_step >= row_bytes ? cloud.row_step : row_bytes;
  if (cloud.point_step == 0 || cloud.data.size() < row_step * (cloud.height - 1) + row_bytes) {
    return core::Status::InvalidArgument(path + ": the data is shorter than the header's " + std::to_string(count) +
                                         " points");
  }
  const pcl::PCLPointField* fields[3] = {FindField(cloud, "x"), FindField(cloud, "y"), FindField(cloud, "z")};
  PointCloud out;
  out.points.reserve(count);
  for (std::uint32_t row = 0; row < cloud.height; ++row) {
    const std::uint8_t* row_data = cloud.data.data() + row * row_step;
    for (std::uint32_t column = 0; column < cloud.width; ++column) {
      const std::uint8_t* point = row_data + static_cast<std::uint64_t>(column) * cloud.point_step;
      const Vec3 p(ReadValue(point + fields[0]->offset, fields[0]->datatype),
                   ReadValue(point + fields[1]->offset, fields[1]->datatype),
                   ReadValue(point + fields[2]->offset, fields[2]->datatype));
      if (p.allFinite()) {
        out.points.push_back(p);
      } else {
        ++out.dropped_non_finite;
      }
    }
  }
  if (out.points.empty() && empty == EmptyCloud::kRefuse) {
    return core::Status::InvalidArgument(path + ": point cloud has no finite points (" +
                                         std::to_string(out.dropped_non_finite) + " non-finite)");
  }
  return out;
}

// PCL's readers are lenient where a wrong point would be silent: an ascii
// value that is not a number is read as 0 (a wall would vanish), a short
// row is padded, and rows beyond the header's count are ignored. So the data
// is checked against the header first: ascii, every row holds one number
// per field value and there are exactly width x height rows; binary, the
// file holds width x height points after the header, no fewer, no more.
core::Status CheckPcdData(const std::string& path, const pcl::PCLPointCloud2& header, int data_type,
                          unsigned int data_offset) {
  {
    // The DATA line ends the header; PCL reads a header without one, or an
    // unknown encoding, as ascii.
    std::ifstream in(path);
    std::string line, encoding;
    while (core::ReadBoundedLine(in, kMaxHeaderBytes, &line) == core::LineRead::kLine &&
           static_cast<std::uint64_t>(in.tellg()) <= data_offset) {
      if (line.rfind("DATA", 0) == 0) {
        std::istringstream words(line.substr(4));
        words >> encoding;
        break;
      }
    }
    if (encoding.empty()) return core::Status::InvalidArgument(path + ": the PCD header has no DATA line");
    if (encoding != "ascii" && encoding != "binary" && encoding != "binary_compressed") {
      return core::Status::InvalidArgument(path + ": unknown PCD encoding 'DATA " + encoding +
                                           "' (expected ascii, binary or binary_compressed)");
    }
  }
  const std::uint64_t count = static_cast<std::uint64_t>(header.width) * header.height;
  std::uint64_t values_per_point = 0, point_bytes = 0;
  for (const pcl::PCLPointField& field : header.fields) {
    values_per_point += field.count;
    point_bytes += static_cast<std::uint64_t>(field.count) * DatatypeSize(field.datatype);
  }
  if (data_type == 1) {
    std::error_code error;
    const std::uint64_t size = std::filesystem::file_size(path, error);
    if (error) return core::Status::NotFound(path + ": cannot open point cloud file");
    // A few trailing bytes (a final newline) are not a point.
    const std::uint64_t data_bytes = size > data_offset ? size - data_offset : 0;
    if (data_bytes < count * point_bytes || data_bytes >= (count + 1) * point_bytes) {
      return core::Status::InvalidArgument(
          path + ": the PCD header says " + std::to_string(count) + " points (" + std::to_string(count * point_bytes) +
          " bytes of data) but the file holds " + std::to_string(data_bytes) + " bytes after the header");
    }
    return core::Status::Ok();
  }
  if (data_type == 2) {
    // binary_compressed: two uint32 sizes, then the LZF data. PCL allocates
    // what the header and the uncompressed size claim before it notices a
    // lie (4 GB for a 1 kB file), so both are checked against the file here.
    std::error_code error;
    const std::uint64_t size = std::filesystem::file_size(path, error);
    std::ifstream in(path, std::ios::binary);
    std::uint32_t sizes[2] = {0, 0};
    if (error || size < static_cast<std::uint64_t>(data_offset) + 8 || !in.seekg(data_offset) ||
        !in.read(reinterpret_cast<char*>(sizes), sizeof(sizes))) {
      return core::Status::InvalidArgument(path + ": PCD binary_compressed data is missing its sizes");
    }
    const std::uint64_t compressed = sizes[0], uncompressed = sizes[1];
    if (compressed > size - data_offset - 8) {
      return core::Status::InvalidArgument(path + ": PCD binary_compressed data claims " + std::to_string(compressed) +
                                           " compressed bytes, the file holds " +
                                           std::to_string(size - data_offset - 8));
    }
    if (uncompressed != count * point_bytes) {
      return core::Status::InvalidArgument(path + ": the PCD header says " + std::to_string(count) + " points (" +
                                           std::to_string(count * point_bytes) +
                                           " bytes) but the compressed data unpacks to " +
                                           std::to_string(uncompressed));
    }
    return core::Status::Ok();
  }
  if (data_type != 0) return core::Status::Ok();
  std::ifstream in(path);
  in.seekg(data_offset);
  std::string line;
  std::uint64_t rows = 0, line_number = 0;
  const std::size_t max_row = kMaxRowBytes + 64 * values_per_point;
  for (core::LineRead got; (got = core::ReadBoundedLine(in, max_row, &line)) != core::LineRead::kEnd;) {
    ++line_number;
    if (got == core::LineRead::kTooLong) {
      return core::Status::InvalidArgument(path + ": PCD data row " + std::to_string(rows + 1) + " is longer than " +
                                           std::to_string(max_row) + " characters");
    }
    const size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    std::uint64_t values = 0;
    const char* cursor = line.c_str() + first;
    while (*cursor != '\0') {
      char* end = nullptr;
      std::strtod(cursor, &end);
      if (end == cursor) {
        return core::Status::InvalidArgument(path + ": PCD data row " + std::to_string(rows + 1) +
                                             " holds something that is not a number: '" + line.substr(0, 60) + "'");
      }
      ++values;
      cursor = end;
      while (*cursor == ' ' || *cursor == '\t' || *cursor == '\r') ++cursor;
    }
    if (values != values_per_point) {
      return core::Status::InvalidArgument(path + ": PCD data row " + std::to_string(rows + 1) + " has " +
                                           std::to_string(values) + " values, the header's fields need " +
                                           std::to_string(values_per_point));
    }
    if (++rows > count) break;
  }
  if (rows != count) {
    return core::Status::InvalidArgument(path + ": the PCD header says " + std::to_string(count) + " points but the data " +
                                         (rows > count ? "holds more" : "holds " + std::to_string(rows)));
  }
  return core::Status::Ok();
}

// PCL's PLY reader, like its PCD reader, reads a word in an ascii row as a
// NaN (dropped later: a wall would vanish) and ignores extra rows. For ascii
// PLY every element's rows are checked here: numbers only, exactly one per
// scalar property (at least that many with list properties), and exactly
// the counts the header declares. Binary PLY is left to PCL.
core::Status CheckPlyAsciiData(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  bool ascii = false;
  struct Element {
    std::string name;
    std::uint64_t count = 0;
    std::uint64_t scalars = 0;
    bool has_list = false;
  };
  std::vector<Element> elements;
  while (core::ReadBoundedLine(in, kMaxHeaderBytes, &line) == core::LineRead::kLine) {
    std::istringstream words(line);
    std::string keyword;
    words >> keyword;
    if (keyword == "format") {
      std::string format;
      words >> format;
      ascii = format == "ascii";
    } else if (keyword == "element") {
      Element e;
      words >> e.name >> e.count;
      elements.push_back(e);
    } else if (keyword == "property" && !elements.empty()) {
      std::string type;
      words >> type;
      if (type == "list") {
        elements.back().has_list = true;
      } else {
        ++elements.back().scalars;
      }
    } else if (keyword == "end_header") {
      break;
    }
  }
  if (!ascii) return core::Status::Ok();
  for (const Element& e : elements) {
    for (std::uint64_t row = 0; row < e.count; ++row) {
      const std::size_t max_row = kMaxRowBytes + 64 * e.scalars;
      const core::LineRead got = core::ReadBoundedLine(in, max_row, &line);
      if (got == core::LineRead::kTooLong) {
        return core::Status::InvalidArgument(path + ": PLY " + e.name + " row " + std::to_string(row + 1) +
                                             " is longer than " + std::to_string(max_row) + " characters");
      }
      if (got == core::LineRead::kEnd) {
        return core::Status::InvalidArgument(path + ": the PLY header says " + std::to_string(e.count) + " " +
                                             e.name + " rows but the data holds " + std::to_string(row));
      }
      std::uint64_t values = 0;
      const char* cursor = line.c_str();
      while (*cursor == ' ' || *cursor == '\t' || *cursor == '\r') ++cursor;
      while (*cursor != '\0') {
        char* end = nullptr;
        std::strtod(cursor, &end);
        if (end == cursor) {
          return core::Status::InvalidArgument(path + ": PLY " + e.name + " row " + std::to_string(row + 1) +
                                               " holds something that is not a number: '" + line.substr(0, 60) +
                                               "'");
        }
        ++values;
        cursor = end;
        while (*cursor == ' ' || *cursor == '\t' || *cursor == '\r') ++cursor;
      }
      if (e.has_list ? values < e.scalars : values != e.scalars) {
        return core::Status::InvalidArgument(path + ": PLY " + e.name + " row " + std::to_string(row + 1) + " has " +
                                             std::to_string(values) + " values, the header's properties need " +
                                             std::to_string(e.scalars));
      }
    }
  }
  for (core::LineRead got; (got = core::ReadBoundedLine(in, kMaxRowBytes, &line)) != core::LineRead::kEnd;) {
    if (got == core::LineRead::kTooLong || line.find_first_not_of(" \t\r") != std::string::npos) {
      return core::Status::InvalidArgument(path + ": the PLY data holds more rows than its header declares");
    }
  }
  return core::Status::Ok();
}

core::Status CheckRegularFile(const std::string& path) {
  std::error_code error;
  const std::filesystem::file_status status = std::filesystem::status(path, error);
  if (error || !std::filesystem::exists(status)) return core::Status::NotFound(path + ": cannot open point cloud file");
  if (!std::filesystem::is_regular_file(status)) {
    return core::Status::InvalidArgument(path + ": not a regular file (a point cloud must be a PCD or PLY file)");
  }
  if (!std::ifstream(path).good()) return core::Status::NotFound(path + ": cannot open point cloud file");
  return core::Status::Ok();
}

// PCL's header reader sizes the cloud's buffer from the header alone (a
// SIZE of 4999999999999999999 made it allocate 6 GB; found by fuzzing), so
// the header text is checked first: SIZE 1, 2, 4 or 8, TYPE F, I or U, COUNT
// 1..4096, as many of each as FIELDS, a WIDTH and HEIGHT whose data the file
// can hold (binary: the bytes; ascii: at least a byte a point; compressed:
// 256 times the file), at most 1 GiB of point data, and a DATA line within
// the first 64 KiB.
// PCL's header reader matches keywords by prefix ("TYPEx" is TYPE), splits
// on spaces, tabs and carriage returns only, keeps reading keyword lines
// after DATA, and allocates POINTS x point step as soon as it reads POINTS.
// So the header is held to the PCD specification here before PCL sees it:
// the keywords exactly, each at most once and in the specification's order,
// no control characters, POINTS = WIDTH x HEIGHT, and nothing after DATA
// that PCL would still take for a header line.
std::string PcdHeaderProblem(const std::string& path) {
  static const char* const kKeywords[] = {"VERSION", "FIELDS", "SIZE",      "TYPE",   "COUNT",
                                          "WIDTH",   "HEIGHT", "VIEWPOINT", "POINTS", "DATA"};
  constexpr int kKeywordCount = sizeof(kKeywords) / sizeof(kKeywords[0]);
  std::error_code error;
  const std::uintmax_t file_size = std::filesystem::file_size(path, error);
  if (error) return "cannot read the file's size";
  std::ifstream in(path, std::ios::binary);
  std::string line;
  std::size_t read = 0;
  int line_number = 0;
  std::vector<std::string> fields, sizes, types, counts;
  std::uint64_t width = 0, height = 1, points = 0;
  bool have_width = false, have_points = false;
  int last_keyword = -1;
  auto tokens_of = [](const std::string& text) {  // split as PCL does
    std::vector<std::string> out;
    std::string word;
    for (char c : text) {
      if (c == ' ' || c == '\t' || c == '\r') {
        if (!word.empty()) out.push_back(word);
        word.clear();
      } else {
        word += c;
      }
    }
    if (!word.empty()) out.push_back(word);
    return out;
  };
  auto printable = [](const std::string& word) {
    std::string out;
    for (char c : word.substr(0, 24)) out += std::isprint(static_cast<unsigned char>(c)) ? c : '?';
    return out;
  };
  const auto whole_number = core::ParseWholeNumber;
  auto keyword_prefix = [&](const std::string& token) {
    for (const char* keyword : kKeywords) {
      if (token.compare(0, std::strlen(keyword), keyword) == 0) return true;
    }
    return token.compare(0, 7, "COLUMNS") == 0;
  };
  for (core::LineRead got; (got = core::ReadBoundedLine(in, kMaxHeaderBytes, &line)) != core::LineRead::kEnd;) {
    read += line.size() + 1;
    ++line_number;
    if (got == core::LineRead::kTooLong || read > kMaxHeaderBytes) return "PCD header longer than 64 KiB";
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    for (char c : line) {
      if (static_cast<unsigned char>(c) < 0x20 && c != '\t') {
        return "control character in header line " + std::to_string(line_number);
      }
    }
    std::vector<std::string> values = tokens_of(line);
    if (values.empty()) continue;
    std::string keyword = values.front();
    values.erase(values.begin());
    if (keyword == "COLUMNS") keyword = "FIELDS";  // the older name
    int index = -1;
    for (int k = 0; k < kKeywordCount; ++k) {
      if (keyword == kKeywords[k]) index = k;
    }
    if (index < 0 && keyword.find_first_of("0123456789") == 0) {
      return "no DATA line in the header (line " + std::to_string(line_number) + " is data)";
    }
    if (index < 0) return "unknown header keyword '" + printable(keyword) + "' on line " + std::to_string(line_number);
    if (index <= last_keyword) {
      return keyword + " on line " + std::to_string(line_number) +
             " is repeated or out of the PCD order (VERSION FIELDS SIZE TYPE COUNT WIDTH HEIGHT VIEWPOINT POINTS DATA)";
    }
    last_keyword = index;
    if (keyword == "FIELDS") fields = values;
    else if (keyword == "SIZE") sizes = values;
    else if (keyword == "TYPE") types = values;
    else if (keyword == "COUNT") counts = values;
    else if (keyword == "WIDTH" || keyword == "HEIGHT" || keyword == "POINTS") {
      std::uint64_t value = 0;
      if (values.size() != 1 || !whole_number(values[0], 0xffffffffULL, &value)) return keyword + " is not a whole number below 2^32";
      if (keyword == "POINTS") {
        points = value;
        have_points = true;
      } else {
        (keyword == "WIDTH" ? width : height) = value;
        have_width = have_width || keyword == "WIDTH";
      }
    } else if (keyword == "DATA") {
      const std::string kind = values.empty() ? "" : values[0];
      if (values.size() != 1 || (kind != "ascii" && kind != "binary" && kind != "binary_compressed")) {
        return "unknown PCD encoding 'DATA " + printable(kind) + "' (ascii, binary or binary_compressed)";
      }
      if (fields.empty() || !have_width) return "header without FIELDS or WIDTH before DATA";
      if (types.empty()) types.assign(fields.size(), "F");  // PCL's default
      if (sizes.size() != fields.size() || types.size() != fields.size() ||
          (!counts.empty() && counts.size() != fields.size())) {
        return "SIZE, TYPE and COUNT must have one entry per field";
      }
      std::uint64_t point_step = 0;
      for (size_t i = 0; i < fields.size(); ++i) {
        std::uint64_t size = 0, count = 1;
        if (!whole_number(sizes[i], 8, &size) || (size != 1 && size != 2 && size != 4 && size != 8)) {
          return "SIZE of field '" + printable(fields[i]) + "' is not 1, 2, 4 or 8";
        }
        if (types[i] != "F" && types[i] != "I" && types[i] != "U") {
          return "TYPE of field '" + printable(fields[i]) + "' is not F, I or U";
        }
        if (!counts.empty() && (!whole_number(counts[i], 4096, &count) || count == 0)) {
          return "COUNT of field '" + printable(fields[i]) + "' is not in 1..4096";
        }
        point_step += size * count;
      }
      const std::uint64_t cloud_points = width * height;  // both below 2^32: no overflow
      if (have_points && points != cloud_points) {
        return "POINTS " + std::to_string(points) + " is not WIDTH x HEIGHT = " + std::to_string(cloud_points);
      }
      const long double bytes = static_cast<long double>(cloud_points) * point_step;
      if (bytes > static_cast<long double>(1ULL << 30)) return "header claims more than 1 GiB of point data";
      const std::uintmax_t rest = file_size > read ? file_size - read : 0;
      if (kind == "binary" && bytes > rest) return "header claims more points than the binary data holds";
      if (kind == "ascii" && cloud_points > rest) return "header claims more points than the file holds";
      if (kind == "binary_compressed" && bytes > 256.0L * file_size) return "header claims more points than compressed data can hold";
      // PCL reads on past DATA while lines look like header lines (blank,
      // comments, keywords): a keyword there would change the header it uses.
      std::size_t looked = 0;
      while (looked < kMaxHeaderBytes && core::ReadBoundedLine(in, kMaxHeaderBytes, &line) == core::LineRead::kLine) {
        looked += line.size() + 1;
        const std::vector<std::string> words = tokens_of(line);
        if (words.empty() || words[0][0] == '#') continue;
        if (keyword_prefix(words[0])) return "a header keyword follows the DATA line";
        break;
      }
      return "";
    }
  }
  return "no DATA line in the header";
}

std::string LowerExtension(const std::string& path) {
  std::string extension = std::filesystem::path(path).extension().string();
  for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return extension;
}

}  // namespace

core::Result<PointCloud> LoadPcd(const std::string& path, EmptyCloud empty) {
  SilencePcl();
  QUADHAND_RETURN_IF_ERROR(CheckRegularFile(path));
  if (const std::string problem = PcdHeaderProblem(path); !problem.empty()) {
    return core::Status::InvalidArgument(path + ": not a readable PCD file (" + problem + ")");
  }
  pcl::PCLPointCloud2 blob;
  pcl::PCDReader reader;
  // PCL 1.13 accepts a header-less file in readHeader and then crashes in
  // read(), and throws on some headers (negative or huge WIDTH), so the
  // header is validated here before any data is read.
  int data_type = 0;
  unsigned int data_offset = 0;
  try {
    Eigen::Vector4f origin;
    Eigen::Quaternionf orientation;
    int version = 0;
    if (reader.readHeader(path, blob, origin, orientation, version, data_type, data_offset) < 0) {
      return core::Status::InvalidArgument(path + ": not a readable PCD file (bad header)");
    }
  } catch (const std::exception& e) {
    return core::Status::InvalidArgument(path + ": not a readable PCD file (bad header: " + e.what() + ")");
  }
  QUADHAND_RETURN_IF_ERROR(CheckCoordinateFields(blob, path, "PCD"));
  if (static_cast<std::uint64_t>(blob.width) * blob.height == 0) {
    if (empty == EmptyCloud::kAllow) return PointCloud{};
    return core::Status::InvalidArgument(path + ": point cloud has no finite points (it is empty)");
  }
  QUADHAND_RETURN_IF_ERROR(CheckPcdData(path, blob, data_type, data_offset));
  int result = -1;
  try {
    result = reader.read(path, blob);
  } catch (const std::exception& e) {  // PCL throws on some malformed data
    return core::Status::InvalidArgument(path + ": not a readable PCD file: " + e.what());
  }
  if (result < 0) return core::Status::InvalidArgument(path + ": not a readable PCD file (bad header or data)");
  return ExtractPoints(blob, path, "PCD", empty);
}

core::Result<PointCloud> LoadPly(const std::string& path, EmptyCloud empty) {
  SilencePcl();
  QUADHAND_RETURN_IF_ERROR(CheckRegularFile(path));
  {
    // PCL sizes its buffers from the header and reads its lines loosely.
    std::error_code error;
    const std::uintmax_t size = std::filesystem::file_size(path, error);
    std::ifstream in(path, std::ios::binary);
    std::string start(65536, '\0');
    in.read(start.data(), static_cast<std::streamsize>(start.size()));
    start.resize(static_cast<std::size_t>(in.gcount()));
    auto header = core::ParsePlyHeader(start, error ? 0 : size);
    if (!header.ok()) return header.status().WithPrefix(path + ": not a readable PLY file");
  }
  QUADHAND_RETURN_IF_ERROR(CheckPlyAsciiData(path));
  pcl::PCLPointCloud2 blob;
  pcl::PLYReader reader;
  int result = -1;
  try {
    result = reader.read(path, blob);
  } catch (const std::exception& e) {
    return core::Status::InvalidArgument(path + ": not a readable PLY file: " + e.what());
  }
  if (result < 0) return core::Status::InvalidArgument(path + ": not a readable PLY file (bad header or data)");
  return ExtractPoints(blob, path, "PLY", empty);
}

core::Result<PointCloud> LoadPointCloud(const std::string& path, EmptyCloud empty) {
  const std::string extension = LowerExtension(path);
  if (extension == ".ply") return LoadPly(path, empty);
  if (extension == ".pcd") return LoadPcd(path, empty);
  QUADHAND_RETURN_IF_ERROR(CheckRegularFile(path));
  return core::Status::InvalidArgument(path + ": unknown point cloud format '" + extension +
                                       "' (expected .pcd or .ply)");
}

core::Status WritePcd(const std::string& path, const std::vector<Vec3>& points, PcdEncoding encoding) {
  SilencePcl();
  pcl::PointCloud<pcl::PointXYZ> cloud;
  cloud.reserve(points.size());
  for (const Vec3& p : points) {
    cloud.push_back(pcl::PointXYZ(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())));
  }
  const std::string temporary = path + ".tmp-" + std::to_string(static_cast<long>(getpid()));
  pcl::PCDWriter writer;
  int result = -1;
  try {
    switch (encoding) {
      case PcdEncoding::kAscii: result = writer.writeASCII(temporary, cloud, 9); break;
      case PcdEncoding::kBinary: result = writer.writeBinary(temporary, cloud); break;
      case PcdEncoding::kBinaryCompressed: result = writer.writeBinaryCompressed(temporary, cloud); break;
    }
  } catch (const std::exception& e) {
    result = -1;
  }
  if (result < 0 || std::rename(temporary.c_str(), path.c_str()) != 0) {
    std::remove(temporary.c_str());
    return core::Status::IoError(path + ": cannot write point cloud");
  }
  return core::Status::Ok();
}

}  // namespace quadhand::scene
