// Quadratic B-spline interpolation weights (Steffen et al. 2008; Jiang et al. 2016, eq. 123).
#pragma once

#include <cmath>

namespace firn {

/// Weights of the 3 nodes base, base+1, base+2 for a particle at grid coordinate xg = x / dx,
/// where base = floor(xg - 1/2). They sum to 1 and reproduce linear fields exactly:
/// sum_i w_i (base + i) = xg.
struct QuadraticWeights {
    int base;
    float fx; ///< xg - base, in [0.5, 1.5)
    float w[3];
};

inline QuadraticWeights quadraticWeights(float xg) {
    QuadraticWeights q;
    q.base = static_cast<int>(std::floor(xg - 0.5f));
    q.fx = xg - static_cast<float>(q.base);
    const float a = 1.5f - q.fx, b = q.fx - 1.f, c = q.fx - 0.5f;
    q.w[0] = 0.5f * a * a;
    q.w[1] = 0.75f - b * b;
    q.w[2] = 0.5f * c * c;
    return q;
}

/// For quadratic B-splines the APIC inertia-like tensor is D = dx^2 / 4 I (Jiang et al. 2015),
/// so C = B D^-1 = 4 / dx^2 B.
inline float apicInverseD(float invDx) {
    return 4.f * invDx * invDx;
}

} // namespace firn
