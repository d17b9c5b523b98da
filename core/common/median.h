#pragma once
// Median of a small array, in place: insertion sort (no recursion on the device's stack, no heap).

namespace bv {

/// Median of v[0..n), n >= 1 (reorders v). Meant for the few-dozen-sample windows of the watches.
inline float MedianInPlace(float* v, int n) {
  for (int i = 1; i < n; ++i) {
    const float x = v[i];
    int j = i - 1;
    while (j >= 0 && v[j] > x) v[j + 1] = v[j], --j;
    v[j + 1] = x;
  }
  return n % 2 ? v[n / 2] : 0.5f * (v[n / 2 - 1] + v[n / 2]);
}

}  // namespace bv
