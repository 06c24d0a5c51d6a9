#include "quadhand/link/fault_channel.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "quadhand/core/file_util.h"
#include "quadhand/core/text.h"
#include "quadhand/core/yaml_text.h"

namespace quadhand::link {
namespace {

using core::Format;

bool Fraction(double v) { return std::isfinite(v) && v >= 0.0 && v <= 1.0; }

}  // namespace

bool LinkFaults::IsValid(std::string* why) const {
  auto fail = [why](const std::string& message) {
    if (why != nullptr) *why = message;
    return false;
  };
  if (!(std::isfinite(loss) && loss >= 0.0 && loss < 1.0)) return fail("loss must be in [0, 1)");
  if (!(std::isfinite(burst) && burst >= 1.0 && burst <= 1e6)) return fail("burst must be in [1, 1e6] datagrams");
  // The chain's entry probability loss / (burst (1 - loss)) must be a probability.
  if (burst > 1.0 && loss / (burst * (1.0 - loss)) > 1.0) {
    return fail(Format("loss %g cannot be reached with bursts of %g (at most burst / (burst + 1))", loss, burst));
  }
  if (!(std::isfinite(delay) && delay >= 0.0 && delay <= 60.0)) return fail("delay must be in [0, 60] s");
  if (!(std::isfinite(jitter) && jitter >= 0.0 && jitter <= 60.0)) return fail("jitter must be in [0, 60] s");
  if (!Fraction(duplicate)) return fail("duplicate must be in [0, 1]");
  if (!Fraction(corrupt)) return fail("corrupt must be in [0, 1]");
  for (const LinkOutage& o : outages) {
    if (!(std::isfinite(o.start) && o.start >= 0.0 && std::isfinite(o.length) && o.length > 0.0)) {
      return fail("an outage needs start >= 0 and length > 0 (s)");
    }
  }
  return true;
}

bool LinkFaults::Perfect() const {
  return loss == 0.0 && delay == 0.0 && jitter == 0.0 && duplicate == 0.0 && corrupt == 0.0 && outages.empty();
}

FaultChannel::FaultChannel(const LinkFaults& faults, uint64_t seed) : faults_(faults), random_(seed) {}

double FaultChannel::DrawDelay() {
  if (faults_.jitter <= 0.0) return faults_.delay;
  std::uniform_real_distribution<double> spread(faults_.delay - faults_.jitter, faults_.delay + faults_.jitter);
  return std::max(0.0, spread(random_));
}

void FaultChannel::Schedule(double due, std::vector<uint8_t> bytes) {
  if (faults_.fifo) due = std::max(due, last_due_);
  last_due_ = std::max(last_due_, due);
  in_flight_.push_back({due, next_sequence_, std::move(bytes)});
}

void FaultChannel::Push(double t, std::vector<uint8_t> bytes) {
  ++stats_.pushed;
  ++next_sequence_;
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  // Every draw is made for every datagram, whatever the outcome, so that
  // one fault's setting does not shift the random sequence of the others.
  const double loss_draw = unit(random_);
  const double duplicate_draw = unit(random_);
  const double corrupt_draw = unit(random_);
  const uint64_t byte_draw = random_();
  const double delay = DrawDelay();
  const double duplicate_delay = DrawDelay();

  bool lost = false;
  if (faults_.burst <= 1.0) {
    lost = loss_draw < faults_.loss;
  } else {
    const double leave = 1.0 / faults_.burst;
    const double enter = faults_.loss / (faults_.burst * (1.0 - faults_.loss));
    in_burst_ = in_burst_ ? loss_draw >= leave : loss_draw < enter;
    lost = in_burst_;
  }
  for (const LinkOutage& o : faults_.outages) {
    if (t >= o.start && t < o.start + o.length) {
      ++stats_.lost_in_outage;
      return;
    }
  }
  if (lost) {
    ++stats_.lost;
    return;
  }
  if (corrupt_draw < faults_.corrupt && !bytes.empty()) {
    const size_t at = static_cast<size_t>(byte_draw % bytes.size());
    bytes[at] = static_cast<uint8_t>(bytes[at] ^ static_cast<uint8_t>(1 + (byte_draw >> 32) % 255));
    ++stats_.corrupted;
  }
  if (duplicate_draw < faults_.duplicate) {
    ++stats_.duplicated;
    Schedule(t + duplicate_delay, bytes);
  }
  Schedule(t + delay, std::move(bytes));
}

std::vector<std::vector<uint8_t>> FaultChannel::PopDue(double t) {
  std::vector<InFlight> due;
  auto split = std::partition(in_flight_.begin(), in_flight_.end(), [t](const InFlight& f) { return f.due > t; });
  due.assign(std::make_move_iterator(split), std::make_move_iterator(in_flight_.end()));
  in_flight_.erase(split, in_flight_.end());
  std::sort(due.begin(), due.end(), [](const InFlight& a, const InFlight& b) {
    return a.due != b.due ? a.due < b.due : a.sequence < b.sequence;
  });
  std::vector<std::vector<uint8_t>> out;
  out.reserve(due.size());
  for (InFlight& f : due) {
    if (delivered_any_ && f.sequence < highest_delivered_) ++stats_.reordered;
    delivered_any_ = true;
    highest_delivered_ = std::max(highest_delivered_, f.sequence);
    ++stats_.delivered;
    out.push_back(std::move(f.bytes));
  }
  return out;
}

std::optional<double> FaultChannel::NextDue() const {
  if (in_flight_.empty()) return std::nullopt;
  double next = std::numeric_limits<double>::infinity();
  for (const InFlight& f : in_flight_) next = std::min(next, f.due);
  return next;
}

// ------------------------------------------------------------------ config

namespace {

core::Status KeyError(const std::string& name, const std::string& key, const std::string& problem) {
  return core::Status::InvalidArgument(name + ": " + key + ": " + problem);
}

core::Result<double> Number(const YAML::Node& node, const std::string& name, const std::string& key) {
  double v = 0.0;
  if (!node.IsScalar() || !YAML::convert<double>::decode(node, v) || !std::isfinite(v)) {
    return KeyError(name, key, "expected a finite number");
  }
  return v;
}

core::Result<std::vector<LinkOutage>> Outages(const YAML::Node& node, const std::string& name, const std::string& key) {
  if (!node.IsSequence()) return KeyError(name, key, "expected a list of {start, length} maps");
  std::vector<LinkOutage> outages;
  for (size_t i = 0; i < node.size(); ++i) {
    const std::string item_key = key + "[" + std::to_string(i) + "]";
    const YAML::Node item = node[i];
    if (!item.IsMap()) return KeyError(name, item_key, "expected a map with start and length (s)");
    LinkOutage o;
    bool have_start = false, have_length = false;
    for (const auto& kv : item) {
      const std::string k = kv.first.as<std::string>();
      auto v = Number(kv.second, name, item_key + "." + k);
      if (!v.ok()) return v.status();
      if (k == "start") {
        o.start = *v;
        have_start = true;
      } else if (k == "length") {
        o.length = *v;
        have_length = true;
      } else {
        return KeyError(name, item_key + "." + k, "unknown key (start, length)");
      }
    }
    if (!have_start || !have_length) return KeyError(name, item_key, "needs both start and length (s)");
    if (!(o.start >= 0.0)) return KeyError(name, item_key + ".start", "must be >= 0 s");
    if (!(o.length > 0.0)) return KeyError(name, item_key + ".length", "must be > 0 s");
    outages.push_back(o);
  }
  return outages;
}

// Applies the keys of one direction's map onto `faults`.
core::Status ApplyDirection(const YAML::Node& node, const std::string& name, const std::string& section,
                            LinkFaults* faults) {
  if (!node.IsMap()) return KeyError(name, section, "expected a map of faults");
  for (const auto& kv : node) {
    const std::string k = kv.first.as<std::string>();
    const std::string key = section + "." + k;
    if (k == "outages") {
      auto outages = Outages(kv.second, name, key);
      if (!outages.ok()) return outages.status();
      faults->outages.insert(faults->outages.end(), outages->begin(), outages->end());
      continue;
    }
    if (k == "fifo") {
      bool b = false;
      if (!kv.second.IsScalar() || !YAML::convert<bool>::decode(kv.second, b)) {
        return KeyError(name, key, "expected true or false");
      }
      faults->fifo = b;
      continue;
    }
    double* field = k == "loss"        ? &faults->loss
                    : k == "burst"     ? &faults->burst
                    : k == "delay"     ? &faults->delay
                    : k == "jitter"    ? &faults->jitter
                    : k == "duplicate" ? &faults->duplicate
                    : k == "corrupt"   ? &faults->corrupt
                                       : nullptr;
    if (field == nullptr) {
      return KeyError(name, key, "unknown key (loss, burst, delay, jitter, fifo, duplicate, corrupt, outages)");
    }
    auto v = Number(kv.second, name, key);
    if (!v.ok()) return v.status();
    *field = *v;
    LinkFaults probe = *faults;
    probe.outages.clear();
    if (std::string why; !probe.IsValid(&why)) return KeyError(name, key, why);
  }
  return core::Status::Ok();
}

}  // namespace

core::Result<LinkFaultConfig> ParseLinkFaultConfig(const std::string& text, const std::string& name) {
  QUADHAND_RETURN_IF_ERROR(core::CheckYamlText(text, name));
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    return core::Status::InvalidArgument(name + ": not valid YAML: " + e.what());
  }
  LinkFaultConfig config;
  if (root.IsNull()) return config;
  if (!root.IsMap()) return core::Status::InvalidArgument(name + ": expected a map (seed, both, up, down, outages)");
  try {
    // `both` first, then each direction over it, whatever the file's order.
    LinkFaults both;
    std::vector<LinkOutage> outages;
    for (const auto& kv : root) {
      const std::string k = kv.first.as<std::string>();
      if (k == "seed") {
        uint64_t seed = 0;
        if (!kv.second.IsScalar() || !YAML::convert<uint64_t>::decode(kv.second, seed)) {
          return KeyError(name, k, "expected a whole number >= 0");
        }
        config.seed = seed;
      } else if (k == "both") {
        QUADHAND_RETURN_IF_ERROR(ApplyDirection(kv.second, name, k, &both));
      } else if (k == "outages") {
        auto parsed = Outages(kv.second, name, k);
        if (!parsed.ok()) return parsed.status();
        outages = *parsed;
      } else if (k != "up" && k != "down") {
        return KeyError(name, k, "unknown key (seed, both, up, down, outages)");
      }
    }
    both.outages.insert(both.outages.end(), outages.begin(), outages.end());
    config.up = both;
    config.down = both;
    if (root["up"]) QUADHAND_RETURN_IF_ERROR(ApplyDirection(root["up"], name, "up", &config.up));
    if (root["down"]) QUADHAND_RETURN_IF_ERROR(ApplyDirection(root["down"], name, "down", &config.down));
  } catch (const YAML::Exception& e) {
    return core::Status::InvalidArgument(name + ": " + e.what());
  }
  for (const auto* faults : {&config.up, &config.down}) {
    if (std::string why; !faults->IsValid(&why)) {
      return core::Status::InvalidArgument(name + ": " + (faults == &config.up ? "up: " : "down: ") + why);
    }
  }
  return config;
}

core::Result<LinkFaultConfig> LoadLinkFaultConfig(const std::string& path) {
  auto text = core::ReadFileToString(path);
  if (!text.ok()) return text.status();
  return ParseLinkFaultConfig(*text, path);
}

}  // namespace quadhand::link
