#include "tools/ballvision/stats.h"

#include <algorithm>
#include <cmath>

namespace bv::cli {

double Percentile(std::vector<double> v, double p) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const double pos = p * static_cast<double>(v.size() - 1);
  const size_t i = static_cast<size_t>(pos);
  const double f = pos - static_cast<double>(i);
  return i + 1 < v.size() ? v[i] * (1 - f) + v[i + 1] * f : v[i];
}

double Median(std::vector<double> v) { return Percentile(std::move(v), 0.5); }

}  // namespace bv::cli
