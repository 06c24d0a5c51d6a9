#include "quadhand/explore/look_round.h"

#include <algorithm>
#include <cmath>

namespace quadhand::explore {
namespace {

// The horizon in bins of 5 degrees.
constexpr int kBins = 72;
constexpr double kBin = 2.0 * M_PI / kBins;

double Wrap(double angle) { return std::remainder(angle, 2.0 * M_PI); }

}  // namespace

LookRound::LookRound(double field_of_view)
    : field_of_view_(std::isfinite(field_of_view) ? std::clamp(field_of_view, kBin, 2.0 * M_PI) : kBin),
      looked_(kBins, false) {}

void LookRound::Clear() { std::fill(looked_.begin(), looked_.end(), false); }

int LookRound::BinOf(double heading) const {
  const double from_zero = Wrap(heading) + M_PI;  // [0, 2 pi]
  return std::clamp(static_cast<int>(std::floor(from_zero / kBin)), 0, kBins - 1);
}

void LookRound::Looked(double heading) {
  if (!std::isfinite(heading)) return;
  // A bin is looked along when its centre is inside the view.
  for (int b = 0; b < kBins; ++b) {
    const double centre = -M_PI + (b + 0.5) * kBin;
    if (std::abs(Wrap(centre - heading)) <= 0.5 * field_of_view_ + 1e-9) looked_[static_cast<size_t>(b)] = true;
  }
}

bool LookRound::WasLooked(double heading) const {
  return std::isfinite(heading) && looked_[static_cast<size_t>(BinOf(heading))];
}

std::optional<double> LookRound::Next(double now, double preferred) const {
  if (!std::isfinite(now) || !std::isfinite(preferred)) return std::nullopt;
  if (!WasLooked(preferred)) return Wrap(preferred);
  std::optional<double> best;
  double best_off = 0.0;
  for (int b = 0; b < kBins; ++b) {
    if (looked_[static_cast<size_t>(b)]) continue;
    const double centre = -M_PI + (b + 0.5) * kBin;
    const double off = std::abs(Wrap(centre - preferred));
    if (!best || off < best_off) {
      best = centre;
      best_off = off;
    }
  }
  if (!best) return std::nullopt;
  // Turn past the unlooked heading so that the view's trailing edge takes
  // it in, rather than centring it: half the view is already looked along.
  const double side = Wrap(*best - now) >= 0.0 ? 1.0 : -1.0;
  const double beyond = std::max(0.0, 0.5 * field_of_view_ - kBin);
  return Wrap(*best + side * beyond);
}

std::optional<double> LookRound::HeadingOf(const Pose& sensor_in_world, const Vec3& axis) {
  const Vec3 a = sensor_in_world.rotation() * axis;
  const double horizontal = a.head<2>().norm();
  if (!(horizontal > std::sin(10.0 * M_PI / 180.0) * a.norm())) return std::nullopt;
  return std::atan2(a.y(), a.x());
}

}  // namespace quadhand::explore
