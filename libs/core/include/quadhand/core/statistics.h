// Summaries of measured values (timings per frame or per replan) for the
// programs' reports.
#pragma once

#include <algorithm>
#include <vector>

namespace quadhand::core {

// The value of rank round(q (n - 1)) among the n sorted `values` (q in
// [0, 1]: 0.5 the median, 0.95 the 95th percentile), a value that was
// measured; 0 when there are none.
inline double RankQuantile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  return values[std::min(values.size() - 1, static_cast<size_t>(q * (values.size() - 1) + 0.5))];
}

}  // namespace quadhand::core
