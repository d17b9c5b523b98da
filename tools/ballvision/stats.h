#pragma once
// Small statistics of the host tools: one Median and one Percentile for every command.
#include <vector>

namespace bv::cli {

/// Linear interpolation between the closest ranks (numpy's default): p = 0.5 of an even count
/// is the mean of the two middle values. NaN for an empty vector.
double Percentile(std::vector<double> v, double p);
/// Percentile(v, 0.5).
double Median(std::vector<double> v);

}  // namespace bv::cli
