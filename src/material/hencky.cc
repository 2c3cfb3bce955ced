#include <firn/hencky.h>

namespace firn {

namespace {
/// Terms of the log series needed for float accuracy: the truncation error relative to the
/// strain is about ||X||^n / (n + 1), kept below ~5e-9.
int seriesTerms(float normSq) {
    if (normSq < 1e-6f) return 3; // ||X|| < 1e-3
    if (normSq < 1e-4f) return 4; // < 0.01
    if (normSq < 1e-3f) return 5; // < 0.032
    return 7;                     // < 0.1
}

/// The series sum_{k=1..n} (-1)^(k+1) X^k / k of a symmetric d x d matrix X as the polynomial
/// a0 I + a1 X (+ a2 X^2 in 3D) it equals by Cayley-Hamilton (Gantmacher, The Theory of
/// Matrices, ch. V): X^d = I1 X^(d-1) - ... with X's invariants, so X^k = c0 I + c1 X + c2 X^2
/// and X^(k+1) = c2 I3 I + (c0 - c2 I2) X + (c1 + c2 I1) X^2 (2D: X^2 = I1 X - I2 I). A scalar
/// recurrence on the invariants replaces the n - 1 matrix products of Horner's form; each term
/// X^k is formed as the sum of the same eigenvalue powers, so small terms stay accurate
/// relative to themselves.
template <int D> struct LogSeriesCoefficients {
    float c[3] = {0.f, 0.f, 0.f};
};

template <int D> LogSeriesCoefficients<D> logSeries(float I1, float I2, float I3, float normSq) {
    const int n = seriesTerms(normSq);
    float power[3] = {0.f, 1.f, 0.f}; // X^1
    LogSeriesCoefficients<D> sum;
    for (int k = 1; k <= n; ++k) {
        const float sign = (k & 1) ? 1.f : -1.f;
        for (int a = 0; a < 3; ++a) sum.c[a] += (sign / float(k)) * power[a];
        if (D == 3) {
            const float c0 = power[0], c1 = power[1], c2 = power[2];
            power[0] = c2 * I3, power[1] = c0 - c2 * I2, power[2] = c1 + c2 * I1;
        } else {
            const float c0 = power[0], c1 = power[1];
            power[0] = -c1 * I2, power[1] = c0 + c1 * I1;
        }
    }
    return sum;
}
} // namespace

bool henckyStrainSeries(const Eigen::Matrix3f& H, int dim, Eigen::Matrix3f& eps) {
    if (dim == 2) {
        // Plane strain: F's third row and column are those of I, so X and the strain are zero
        // outside their leading 2 x 2 blocks.
        const float xx = 2.f * H(0, 0) + H(0, 0) * H(0, 0) + H(0, 1) * H(0, 1);
        const float yy = 2.f * H(1, 1) + H(1, 0) * H(1, 0) + H(1, 1) * H(1, 1);
        const float xy = H(0, 1) + H(1, 0) + H(0, 0) * H(1, 0) + H(0, 1) * H(1, 1);
        const float normSq = xx * xx + yy * yy + 2.f * xy * xy;
        if (normSq > 0.01f) return false;
        const LogSeriesCoefficients<2> s = logSeries<2>(xx + yy, xx * yy - xy * xy, 0.f, normSq);
        const float a0 = 0.5f * s.c[0], a1 = 0.5f * s.c[1];
        eps.setZero();
        eps(0, 0) = a0 + a1 * xx, eps(1, 1) = a0 + a1 * yy;
        eps(0, 1) = eps(1, 0) = a1 * xy;
        return true;
    }
    // X = F F^T - I = H + H^T + H H^T, symmetric: its six entries.
    float X[3][3];
    for (int a = 0; a < 3; ++a)
        for (int b = a; b < 3; ++b)
            X[a][b] = X[b][a] =
                H(a, b) + H(b, a) + H(a, 0) * H(b, 0) + H(a, 1) * H(b, 1) + H(a, 2) * H(b, 2);
    const float normSq = X[0][0] * X[0][0] + X[1][1] * X[1][1] + X[2][2] * X[2][2] +
                         2.f * (X[0][1] * X[0][1] + X[0][2] * X[0][2] + X[1][2] * X[1][2]);
    if (normSq > 0.01f) return false;
    float X2[3][3];
    for (int a = 0; a < 3; ++a)
        for (int b = a; b < 3; ++b)
            X2[a][b] = X2[b][a] = X[a][0] * X[0][b] + X[a][1] * X[1][b] + X[a][2] * X[2][b];
    const float I1 = X[0][0] + X[1][1] + X[2][2];
    const float I2 = 0.5f * (I1 * I1 - (X2[0][0] + X2[1][1] + X2[2][2]));
    const float I3 = X[0][0] * (X[1][1] * X[2][2] - X[1][2] * X[1][2]) -
                     X[0][1] * (X[0][1] * X[2][2] - X[1][2] * X[0][2]) +
                     X[0][2] * (X[0][1] * X[1][2] - X[1][1] * X[0][2]);
    const LogSeriesCoefficients<3> s = logSeries<3>(I1, I2, I3, normSq);
    const float a0 = 0.5f * s.c[0], a1 = 0.5f * s.c[1], a2 = 0.5f * s.c[2];
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) eps(a, b) = a1 * X[a][b] + a2 * X2[a][b];
    for (int a = 0; a < 3; ++a) eps(a, a) += a0;
    return true;
}

} // namespace firn
