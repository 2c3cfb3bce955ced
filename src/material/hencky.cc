#include <firn/hencky.h>

namespace firn {

namespace {

/// Terms of the log series: the truncation error relative to the strain is about
/// ||X||^n / (n + 1), below 0.1^7 / 8 ~ 1.3e-8 at the largest ||X|| the series takes. A fixed
/// count keeps every lane of a batch on the same instructions.
constexpr int kSeriesTerms = 7;

/// kHenckyBatch floats in one SIMD register (GCC and Clang vector extension): the arithmetic
/// below runs on all the batch's particles at once, each in its lane.
using Lanes = float __attribute__((vector_size(kHenckyBatch * sizeof(float))));

/// The series sum_{k=1..n} (-1)^(k+1) X^k / k of a symmetric d x d matrix X as the polynomial
/// c0 I + c1 X (+ c2 X^2 in 3D) it equals by Cayley-Hamilton (Gantmacher, The Theory of
/// Matrices, ch. V): X^d = I1 X^(d-1) - ... with X's invariants, so X^k = p0 I + p1 X + p2 X^2
/// and X^(k+1) = p2 I3 I + (p0 - p2 I2) X + (p1 + p2 I1) X^2 (2D: X^2 = I1 X - I2 I). A scalar
/// recurrence on the invariants replaces the n - 1 matrix products of Horner's form; each term
/// X^k is formed as the sum of the same eigenvalue powers, so small terms stay accurate
/// relative to themselves.
template <int D>
inline void logSeries(const Lanes& I1, const Lanes& I2, const Lanes& I3, Lanes& c0, Lanes& c1,
                      Lanes& c2) {
    Lanes p0 = {}, p1 = {}, p2 = {}; // X^1: p1 = 1
    p1 += 1.f;
    c0 = c1 = c2 = Lanes{};
    for (int k = 1; k <= kSeriesTerms; ++k) {
        const float coefficient = ((k & 1) ? 1.f : -1.f) / float(k);
        c0 += coefficient * p0, c1 += coefficient * p1, c2 += coefficient * p2;
        const Lanes q0 = p0, q1 = p1, q2 = p2;
        if (D == 3) {
            p0 = q2 * I3, p1 = q0 - q2 * I2, p2 = q1 + q2 * I1;
        } else {
            p0 = -q1 * I2, p1 = q0 + q1 * I1;
        }
    }
}

template <int D> unsigned seriesBatch(const Eigen::Matrix3f* H, int count, Eigen::Matrix3f* eps) {
    Lanes h[3][3];
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b)
            for (int l = 0; l < kHenckyBatch; ++l) h[a][b][l] = l < count ? H[l](a, b) : 0.f;
    // X = F F^T - I = H + H^T + H H^T (symmetric), X^2, the invariants.
    Lanes x[3][3] = {}, x2[3][3] = {};
    for (int a = 0; a < D; ++a)
        for (int b = a; b < D; ++b) {
            Lanes s = h[a][b] + h[b][a];
            for (int k = 0; k < D; ++k) s += h[a][k] * h[b][k];
            x[a][b] = x[b][a] = s;
        }
    Lanes normSq = {}, I1 = {}, I2 = {}, I3 = {};
    for (int a = 0; a < D; ++a) {
        I1 += x[a][a];
        for (int b = 0; b < D; ++b) normSq += x[a][b] * x[a][b];
    }
    if (D == 3) {
        for (int a = 0; a < 3; ++a)
            for (int b = a; b < 3; ++b) {
                Lanes s = {};
                for (int k = 0; k < 3; ++k) s += x[a][k] * x[k][b];
                x2[a][b] = x2[b][a] = s;
            }
        I2 = 0.5f * (I1 * I1 - (x2[0][0] + x2[1][1] + x2[2][2]));
        I3 = x[0][0] * (x[1][1] * x[2][2] - x[1][2] * x[1][2]) -
             x[0][1] * (x[0][1] * x[2][2] - x[1][2] * x[0][2]) +
             x[0][2] * (x[0][1] * x[1][2] - x[1][1] * x[0][2]);
    } else {
        I2 = x[0][0] * x[1][1] - x[0][1] * x[0][1];
    }
    Lanes c0, c1, c2;
    logSeries<D>(I1, I2, I3, c0, c1, c2);
    c0 *= 0.5f, c1 *= 0.5f, c2 *= 0.5f;
    Lanes e[3][3];
    for (int a = 0; a < D; ++a)
        for (int b = 0; b < D; ++b) e[a][b] = c1 * x[a][b] + (D == 3 ? c2 * x2[a][b] : Lanes{});
    for (int a = 0; a < D; ++a) e[a][a] += c0;
    unsigned ok = 0;
    for (int l = 0; l < count; ++l) {
        if (!(normSq[l] <= 0.01f)) continue;
        ok |= 1u << l;
        eps[l].setZero();
        for (int a = 0; a < D; ++a)
            for (int b = 0; b < D; ++b) eps[l](a, b) = e[a][b][l];
    }
    return ok;
}

} // namespace

unsigned henckyStrainSeries(const Eigen::Matrix3f* displacementGradients, int count, int dim,
                            Eigen::Matrix3f* eps) {
    // Plane strain: F's third row and column are those of I, so X and the strain are zero
    // outside their leading 2 x 2 blocks.
    return dim == 2 ? seriesBatch<2>(displacementGradients, count, eps)
                    : seriesBatch<3>(displacementGradients, count, eps);
}

} // namespace firn
