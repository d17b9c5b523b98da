#pragma once
#include <cmath>
#include <cstdint>

namespace bv {

/// std::lround for a finite float with |x| < 2^31: halves away from zero. The M7 has it as one
/// instruction (vcvta); x86-64 without SSE4.1 calls the library, per boundary pixel and attention
/// sample, so hosts round inline. Outside the domain: INT32_MIN on hosts, the M7's saturated value.
inline int32_t RoundToInt(float x) {
#if defined(__arm__)
  return static_cast<int32_t>(std::lround(x));
#else
  if (!(x > -2147483520.0f && x < 2147483520.0f)) return INT32_MIN;
  const auto t = static_cast<int32_t>(x);     // toward zero
  const float f = x - static_cast<float>(t);  // exact: |f| < 1, same sign as x
  return t + (f >= 0.5f ? 1 : 0) - (f <= -0.5f ? 1 : 0);
#endif
}

}  // namespace bv
