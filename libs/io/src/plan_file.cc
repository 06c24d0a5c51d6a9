#include "quadhand/io/plan_file.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <map>
#include <sstream>

#include "quadhand/core/file_util.h"
#include "quadhand/core/text.h"

namespace quadhand::io {
namespace {

bool ParseNumber(const std::string& text, double* value) {
  const std::string s = core::Trimmed(text);
  if (s.empty()) return false;
  char* end = nullptr;
  errno = 0;
  *value = std::strtod(s.c_str(), &end);
  // ERANGE also flags an underflow to a subnormal or zero (1e-309, which
  // the simulator writes for a rate decaying to rest): that value is finite
  // and right. Only an overflow (inf) is refused.
  return end == s.c_str() + s.size() && std::isfinite(*value) && !(errno == ERANGE && std::abs(*value) > 1.0);
}

}  // namespace

std::vector<std::string> PlanColumns(const std::vector<std::string>& joint_names) {
  std::vector<std::string> columns = {"t",  "px", "py", "pz", "vx", "vy", "vz",  "ax",
                                      "ay", "az", "qw", "qx", "qy", "qz", "yaw", "yaw_rate"};
  for (const auto& name : joint_names) columns.push_back(name);
  for (const auto& name : joint_names) columns.push_back(name + "_rate");
  return columns;
}

void AppendCsvNumber(std::string* line, double value) {
  char buffer[40];
  std::snprintf(buffer, sizeof(buffer), "%.10g", value);
  if (!line->empty()) line->push_back(',');
  *line += buffer;
}

std::string PlanTableCsv(const PlanTable& table) {
  std::string out;
  for (size_t c = 0; c < table.columns.size(); ++c) out += (c == 0 ? "" : ",") + table.columns[c];
  out += '\n';
  std::string line;
  for (Eigen::Index r = 0; r < table.values.rows(); ++r) {
    line.clear();
    for (Eigen::Index c = 0; c < table.values.cols(); ++c) AppendCsvNumber(&line, table.values(r, c));
    out += line;
    out += '\n';
  }
  return out;
}

core::Result<PlanTable> ParsePlanFile(const std::string& text, const std::vector<std::string>& joint_names,
                                      const std::string& source, const std::vector<std::string>& optional_columns,
                                      const std::vector<std::string>& blank_allowed) {
  auto bad = [&](const std::string& what) { return core::Status::InvalidArgument(source + ": " + what); };
  std::istringstream in(text);
  std::string line;
  if (!std::getline(in, line) || core::Trimmed(line).empty()) {
    return bad("empty file (expected a plan CSV header)");
  }
  const std::vector<std::string> header = core::SplitCommas(line);
  std::map<std::string, int> column;
  for (size_t i = 0; i < header.size(); ++i) column.emplace(core::Trimmed(header[i]), static_cast<int>(i));
  PlanTable table;
  table.columns = PlanColumns(joint_names);
  std::vector<int> index;
  for (const auto& name : table.columns) {
    const auto it = column.find(name);
    if (it == column.end()) return bad("missing column '" + name + "' (see contracts.md: plan file)");
    index.push_back(it->second);
  }
  for (const std::string& name : optional_columns) {
    const auto it = column.find(name);
    if (it == column.end()) continue;
    table.columns.push_back(name);
    index.push_back(it->second);
  }

  const size_t width = table.columns.size();
  std::vector<bool> may_be_blank(width, false);
  for (size_t k = 0; k < width; ++k) {
    may_be_blank[k] = std::find(blank_allowed.begin(), blank_allowed.end(), table.columns[k]) != blank_allowed.end();
  }
  std::vector<double> values;
  std::vector<double> row(width);
  int line_number = 1;
  size_t rows = 0;
  while (std::getline(in, line)) {
    ++line_number;
    if (core::Trimmed(line).empty()) continue;
    const std::vector<std::string> fields = core::SplitCommas(line);
    const std::string where = "line " + std::to_string(line_number) + ": ";
    if (fields.size() != header.size()) {
      return bad(where + std::to_string(fields.size()) + " fields, the header has " + std::to_string(header.size()));
    }
    for (size_t k = 0; k < width; ++k) {
      if (may_be_blank[k] && core::Trimmed(fields[index[k]]).empty()) {
        row[k] = std::numeric_limits<double>::quiet_NaN();
        continue;
      }
      if (!ParseNumber(fields[index[k]], &row[k])) {
        return bad(where + "column '" + table.columns[k] + "': not a finite number: '" +
                   core::Trimmed(fields[index[k]]) + "'");
      }
    }
    const double quaternion_norm = std::sqrt(row[10] * row[10] + row[11] * row[11] + row[12] * row[12] + row[13] * row[13]);
    if (std::abs(quaternion_norm - 1.0) > 1e-3) return bad(where + "the quaternion (qw, qx, qy, qz) is not of unit length");
    if (rows > 0 && !(row[0] > values[(rows - 1) * width])) {
      return bad(where + "time " + core::Trimmed(fields[index[0]]) + " does not increase");
    }
    values.insert(values.end(), row.begin(), row.end());
    ++rows;
  }
  if (rows < 2) return bad("a plan needs at least 2 rows, found " + std::to_string(rows));
  table.values = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      values.data(), static_cast<Eigen::Index>(rows), static_cast<Eigen::Index>(width));
  return table;
}

core::Result<PlanTable> LoadPlanFile(const std::string& path, const std::vector<std::string>& joint_names) {
  auto text = core::ReadFileToString(path);
  if (!text.ok()) return text.status();
  return ParsePlanFile(*text, joint_names, path);
}

}  // namespace quadhand::io
