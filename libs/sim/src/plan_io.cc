#include "quadhand/sim/plan_io.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <sstream>

#include "quadhand/core/file_util.h"

namespace quadhand::sim {
namespace {

using core::Status;

const char* const kBaseColumns[] = {"t",  "px", "py", "pz", "vx", "vy", "vz",  "ax",
                                    "ay", "az", "qw", "qx", "qy", "qz", "yaw", "yaw_rate"};

std::vector<std::string> SplitCommas(const std::string& line) {
  std::vector<std::string> fields;
  std::string field;
  std::istringstream in(line);
  while (std::getline(in, field, ',')) fields.push_back(field);
  if (!line.empty() && line.back() == ',') fields.emplace_back();
  return fields;
}

std::string Trim(const std::string& s) {
  const size_t a = s.find_first_not_of(" \t\r");
  if (a == std::string::npos) return "";
  const size_t b = s.find_last_not_of(" \t\r");
  return s.substr(a, b - a + 1);
}

bool ParseNumber(const std::string& text, double* value) {
  const std::string s = Trim(text);
  if (s.empty()) return false;
  char* end = nullptr;
  errno = 0;
  *value = std::strtod(s.c_str(), &end);
  return end == s.c_str() + s.size() && errno != ERANGE && std::isfinite(*value);
}

double WrapAngle(double a) { return std::remainder(a, 2.0 * M_PI); }

void Put(std::string* out, double v) {
  char buffer[40];
  std::snprintf(buffer, sizeof(buffer), "%.10g", v);
  if (!out->empty()) out->push_back(',');
  *out += buffer;
}

}  // namespace

std::string PlanCsvHeader(const std::vector<std::string>& joint_names) {
  std::string header;
  for (const char* c : kBaseColumns) header += (header.empty() ? "" : ",") + std::string(c);
  for (const auto& name : joint_names) header += "," + name;
  for (const auto& name : joint_names) header += "," + name + "_rate";
  return header;
}

std::string PlanCsvRow(const PlanRow& r) {
  std::string out;
  Put(&out, r.t);
  for (int i = 0; i < 3; ++i) Put(&out, r.position[i]);
  for (int i = 0; i < 3; ++i) Put(&out, r.velocity[i]);
  for (int i = 0; i < 3; ++i) Put(&out, r.acceleration[i]);
  Put(&out, r.attitude.w());
  Put(&out, r.attitude.x());
  Put(&out, r.attitude.y());
  Put(&out, r.attitude.z());
  Put(&out, r.yaw);
  Put(&out, r.yaw_rate);
  for (int i = 0; i < r.joints.size(); ++i) Put(&out, r.joints[i]);
  for (int i = 0; i < r.joint_rates.size(); ++i) Put(&out, r.joint_rates[i]);
  return out;
}

std::string WritePlanCsv(const Plan& plan) {
  std::string out = PlanCsvHeader(plan.joint_names) + "\n";
  for (const PlanRow& row : plan.rows) out += PlanCsvRow(row) + "\n";
  return out;
}

core::Result<Plan> ParsePlanCsv(const std::string& text, const std::vector<std::string>& joint_names,
                                const std::string& source) {
  auto bad = [&](const std::string& what) { return Status::InvalidArgument(source + ": " + what); };
  std::istringstream in(text);
  std::string line;
  if (!std::getline(in, line) || Trim(line).empty()) return bad("empty file (expected a plan CSV header)");
  const std::vector<std::string> header = SplitCommas(line);
  std::map<std::string, int> column;
  for (size_t i = 0; i < header.size(); ++i) column.emplace(Trim(header[i]), static_cast<int>(i));
  std::vector<std::string> wanted(std::begin(kBaseColumns), std::end(kBaseColumns));
  for (const auto& name : joint_names) wanted.push_back(name);
  for (const auto& name : joint_names) wanted.push_back(name + "_rate");
  std::vector<int> index;
  for (const auto& name : wanted) {
    const auto it = column.find(name);
    if (it == column.end()) return bad("missing column '" + name + "' (see contracts.md: plan file)");
    index.push_back(it->second);
  }

  Plan plan;
  plan.joint_names = joint_names;
  const int n = static_cast<int>(joint_names.size());
  std::vector<double> v(wanted.size());
  int line_number = 1;
  while (std::getline(in, line)) {
    ++line_number;
    if (Trim(line).empty()) continue;
    const std::vector<std::string> fields = SplitCommas(line);
    if (fields.size() != header.size()) {
      return bad("line " + std::to_string(line_number) + ": " + std::to_string(fields.size()) + " fields, the header has " +
                 std::to_string(header.size()));
    }
    for (size_t k = 0; k < wanted.size(); ++k) {
      if (!ParseNumber(fields[index[k]], &v[k])) {
        return bad("line " + std::to_string(line_number) + ": column '" + wanted[k] + "': not a finite number: '" +
                   Trim(fields[index[k]]) + "'");
      }
    }
    PlanRow r;
    r.t = v[0];
    r.position = Vec3(v[1], v[2], v[3]);
    r.velocity = Vec3(v[4], v[5], v[6]);
    r.acceleration = Vec3(v[7], v[8], v[9]);
    r.attitude = Quat(v[10], v[11], v[12], v[13]);
    if (std::abs(r.attitude.norm() - 1.0) > 1e-3) {
      return bad("line " + std::to_string(line_number) + ": the quaternion (qw, qx, qy, qz) is not of unit length");
    }
    r.attitude.normalize();
    r.yaw = v[14];
    r.yaw_rate = v[15];
    r.joints = VecX(n);
    r.joint_rates = VecX(n);
    for (int k = 0; k < n; ++k) {
      r.joints[k] = v[16 + k];
      r.joint_rates[k] = v[16 + n + k];
    }
    if (!plan.rows.empty() && !(r.t > plan.rows.back().t)) {
      return bad("line " + std::to_string(line_number) + ": time " + Trim(fields[index[0]]) +
                 " does not increase");
    }
    plan.rows.push_back(std::move(r));
  }
  if (plan.rows.size() < 2) return bad("a plan needs at least 2 rows, found " + std::to_string(plan.rows.size()));
  return plan;
}

core::Result<Plan> LoadPlanCsv(const std::string& path, const std::vector<std::string>& joint_names) {
  auto text = core::ReadFileToString(path);
  if (!text.ok()) return text.status();
  return ParsePlanCsv(*text, joint_names, path);
}

Setpoint SamplePlan(const Plan& plan, double t) {
  const std::vector<PlanRow>& rows = plan.rows;
  Setpoint sp;
  if (t <= rows.front().t || t >= rows.back().t) {
    const PlanRow& r = t <= rows.front().t ? rows.front() : rows.back();
    sp.position = r.position;
    sp.velocity = r.velocity;
    sp.acceleration = r.acceleration;
    sp.yaw = r.yaw;
    sp.yaw_rate = r.yaw_rate;
    sp.joints = r.joints;
    sp.joint_rates = r.joint_rates;
    return sp;
  }
  const auto it = std::upper_bound(rows.begin(), rows.end(), t, [](double x, const PlanRow& r) { return x < r.t; });
  const PlanRow& b = *it;
  const PlanRow& a = *(it - 1);
  const double dt = b.t - a.t;
  const double s = (t - a.t) / dt;
  sp.position = (1 - s) * a.position + s * b.position;
  sp.velocity = (1 - s) * a.velocity + s * b.velocity;
  sp.acceleration = (1 - s) * a.acceleration + s * b.acceleration;
  sp.jerk = (b.acceleration - a.acceleration) / dt;
  sp.yaw = WrapAngle(a.yaw + s * WrapAngle(b.yaw - a.yaw));
  sp.yaw_rate = (1 - s) * a.yaw_rate + s * b.yaw_rate;
  sp.joints = (1 - s) * a.joints + s * b.joints;
  sp.joint_rates = (1 - s) * a.joint_rates + s * b.joint_rates;
  return sp;
}

}  // namespace quadhand::sim
