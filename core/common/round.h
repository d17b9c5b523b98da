#pragma once
#include <cstdint>

namespace bv {

/// std::lround for a float, inline: the library's is a call on the host and in newlib, made per
/// boundary pixel and attention sample. Halves round away from zero; NaN and |x| >= 2^31 give
/// INT32_MIN, outside any image.
inline int32_t RoundToInt(float x) {
  if (!(x > -2147483520.0f && x < 2147483520.0f)) return INT32_MIN;
  const auto t = static_cast<int32_t>(x);     // toward zero
  const float f = x - static_cast<float>(t);  // exact: |f| < 1, same sign as x
  return t + (f >= 0.5f ? 1 : 0) - (f <= -0.5f ? 1 : 0);
}

}  // namespace bv
