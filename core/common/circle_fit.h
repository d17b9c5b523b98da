#pragma once
// Kasa's algebraic circle fit: the least-squares x^2 + y^2 + D x + E y + F = 0 over points added
// one by one (sums in float, the 3x3 solve in double by Cramer's rule). Coordinates relative to a
// point near the centre keep the sums well scaled.
#include <cmath>

namespace bv {

struct CircleSums {
  float sxx = 0, sxy = 0, syy = 0, sx = 0, sy = 0, sxz = 0, syz = 0, sz = 0, n = 0;

  void Add(float x, float y) {
    const float z = x * x + y * y;
    sxx += x * x;
    sxy += x * y;
    syy += y * y;
    sx += x;
    sy += y;
    sxz += x * z;
    syz += y * z;
    sz += z;
    n += 1.0f;
  }
  /// Centre (in the points' coordinates) and radius; false when the points fix no circle.
  bool Solve(double& cx, double& cy, double& r) const {
    // [sxx sxy sx; sxy syy sy; sx sy n] (D, E, F) = -(sxz, syz, sz).
    const double a11 = sxx, a12 = sxy, a13 = sx, a22 = syy, a23 = sy, a33 = n;
    const double b1 = -sxz, b2 = -syz, b3 = -sz;
    const double det = a11 * (a22 * a33 - a23 * a23) - a12 * (a12 * a33 - a23 * a13) +
                       a13 * (a12 * a23 - a22 * a13);
    if (!(std::fabs(det) > 1e-9)) return false;
    const double d =
        (b1 * (a22 * a33 - a23 * a23) - a12 * (b2 * a33 - a23 * b3) + a13 * (b2 * a23 - a22 * b3)) /
        det;
    const double e =
        (a11 * (b2 * a33 - a23 * b3) - b1 * (a12 * a33 - a23 * a13) + a13 * (a12 * b3 - b2 * a13)) /
        det;
    const double f =
        (a11 * (a22 * b3 - b2 * a23) - a12 * (a12 * b3 - b2 * a13) + b1 * (a12 * a23 - a22 * a13)) /
        det;
    const double r2 = 0.25 * (d * d + e * e) - f;
    if (!(r2 > 0.0)) return false;
    cx = -0.5 * d;
    cy = -0.5 * e;
    r = std::sqrt(r2);
    return true;
  }
};

}  // namespace bv
