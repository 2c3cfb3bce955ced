// Principal strains and directions of a batch of symmetric 3x3 strains, in SIMD lanes.
//
// The yielding particles' return map needs the Hencky strain's eigenvalues and eigenvectors.
// The series (hencky.cc) gives the strain itself in float; decomposing it directly skips the
// double-precision eigenproblem of F F^T and the three logs (svd.cc), and the Jacobi method,
// unlike the closed-form (trigonometric) solver, is accurate to float precision relative to the
// matrix's norm for every spectrum, double roots included (Demmel & Veselic 1992): the uniaxial
// strain of a resting layer keeps its two equal values equal to round-off.
#include <firn/hencky.h>

#if defined(__AVX__) || defined(__SSE2__)
#include <immintrin.h>
#endif

#include <cmath>

namespace firn {

namespace {

using Lanes = float __attribute__((vector_size(kHenckyBatch * sizeof(float))));

/// Cyclic sweeps over the three off-diagonal pairs. Convergence is quadratic once the
/// off-diagonal part is small; from an arbitrary rotation four sweeps leave it below float
/// round-off of the largest eigenvalue (`firn_tests "Principal strains*"` measures the
/// residual). A fixed count keeps every lane on the same instructions, so a particle's result
/// does not depend on its neighbours in the batch.
constexpr int kJacobiSweeps = 4;

Lanes sqrtLanes(Lanes a) {
#if defined(__AVX__)
    static_assert(kHenckyBatch == 8, "one AVX register of floats");
    return reinterpret_cast<Lanes>(_mm256_sqrt_ps(reinterpret_cast<__m256>(a)));
#elif defined(__SSE2__)
    static_assert(kHenckyBatch == 8, "two SSE registers of floats");
    using Half = float __attribute__((vector_size(4 * sizeof(float))));
    Half lo, hi;
    for (int l = 0; l < 4; ++l) lo[l] = a[l], hi[l] = a[l + 4];
    lo = reinterpret_cast<Half>(_mm_sqrt_ps(reinterpret_cast<__m128>(lo)));
    hi = reinterpret_cast<Half>(_mm_sqrt_ps(reinterpret_cast<__m128>(hi)));
    for (int l = 0; l < 4; ++l) a[l] = lo[l], a[l + 4] = hi[l];
    return a;
#else
    for (int l = 0; l < kHenckyBatch; ++l) a[l] = std::sqrt(a[l]);
    return a;
#endif
}

/// One Jacobi rotation in the (p, q) plane, in every lane: A <- J^T A J zeroes A(p, q), U <- U J
/// accumulates the eigenvectors (Golub & Van Loan, Matrix Computations, sec. 8.5, the symmetric
/// Schur rotation, svd.cc's jacobiRotate). A lane whose A(p, q) is zero takes the identity
/// (t = 0); tau^2 overflows to inf for |A(p, q)| below ~1e-19 |A(q, q) - A(p, p)|, and t = 0
/// then too. (t = sgn(d) b / (|d| + sqrt(d^2 + b^2)) with d = A(q, q) - A(p, p), b = 2 A(p, q),
/// saves a division and 5 % of the sweeps' time, but left U 1.6e-6 from orthogonal against
/// 1.0e-6.) p and q are template arguments so that every index is known and the sweeps stay in
/// registers.
template <int p, int q> inline void rotate(Lanes (&a)[3][3], Lanes (&u)[3][3]) {
    const Lanes zero = {};
    const Lanes one = zero + 1.f;
    const Lanes apq = a[p][q];
    const Lanes safeApq = apq == zero ? one : apq;
    const Lanes tau = (a[q][q] - a[p][p]) / (2.f * safeApq);
    const Lanes absTau = tau < zero ? -tau : tau;
    Lanes t = one / (absTau + sqrtLanes(one + tau * tau));
    t = tau < zero ? -t : t;
    t = apq == zero ? zero : t;
    const Lanes c = one / sqrtLanes(one + t * t);
    const Lanes s = t * c;
    constexpr int r = 3 - p - q; // the untouched index
    const Lanes arp = a[r][p], arq = a[r][q];
    a[p][p] -= t * apq;
    a[q][q] += t * apq;
    a[p][q] = a[q][p] = zero;
    a[r][p] = a[p][r] = c * arp - s * arq;
    a[r][q] = a[q][r] = s * arp + c * arq;
    for (int k = 0; k < 3; ++k) {
        const Lanes ukp = u[k][p], ukq = u[k][q];
        u[k][p] = c * ukp - s * ukq;
        u[k][q] = s * ukp + c * ukq;
    }
}

/// Diagonalises a, in every lane, accumulating the rotations into u (which starts as I).
void jacobiSweeps(Lanes (&a)[3][3], Lanes (&u)[3][3]) {
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) u[i][j] = Lanes{} + (i == j ? 1.f : 0.f);
    for (int sweep = 0; sweep < kJacobiSweeps; ++sweep) {
        rotate<0, 1>(a, u);
        rotate<0, 2>(a, u);
        rotate<1, 2>(a, u);
    }
}

/// Largest ||F F^T - I||_F^2 whose eigenvalues are taken: 1 + lambda >= 0.5, so the absolute
/// round-off of lambda (a few ulps of the norm) stays a few ulps of log(1 + lambda). Beyond it
/// (stretches below ~0.7 or above ~1.2) svd.cc's double F F^T keeps small stretches accurate.
constexpr float kMaxStretchNormSq = 0.25f;

} // namespace

unsigned principalHenckyStrains(const Eigen::Matrix3f* displacementGradients,
                                const Eigen::Matrix3f* series, unsigned inSeries, unsigned wanted,
                                Eigen::Matrix3f* directions, Eigen::Vector3f* values) {
    // Each lane holds the series' strain (symmetrised: symmetric up to round-off in its
    // products) or X = F F^T - I = H + H^T + H H^T, formed as the series forms it (no rounding
    // at 1); lanes not wanted hold zero.
    const unsigned fromSeries = wanted & inSeries, fromStretch = wanted & ~inSeries;
    Lanes a[3][3], u[3][3];
    Lanes normSq = {};
    for (int i = 0; i < 3; ++i)
        for (int j = i; j < 3; ++j)
            for (int l = 0; l < kHenckyBatch; ++l) {
                float value = 0.f;
                if (fromSeries >> l & 1u) {
                    value = 0.5f * (series[l](i, j) + series[l](j, i));
                } else if (fromStretch >> l & 1u) {
                    const Eigen::Matrix3f& h = displacementGradients[l];
                    value = h(i, j) + h(j, i) + h.row(i).dot(h.row(j));
                    normSq[l] += (i == j ? 1.f : 2.f) * value * value;
                }
                a[i][j][l] = a[j][i][l] = value;
            }
    jacobiSweeps(a, u);
    unsigned done = 0;
    for (int l = 0; l < kHenckyBatch; ++l) {
        const bool stretch = fromStretch >> l & 1u;
        if (!(fromSeries >> l & 1u) && !(stretch && normSq[l] <= kMaxStretchNormSq)) continue;
        done |= 1u << l;
        for (int i = 0; i < 3; ++i) {
            // The series' lanes hold the strain; X's its eigenvalues lambda, eps = 1/2 log(1 +
            // lambda).
            values[l][i] = stretch ? 0.5f * std::log1p(a[i][i][l]) : a[i][i][l];
            for (int j = 0; j < 3; ++j) directions[l](i, j) = u[i][j][l];
        }
    }
    return done;
}

} // namespace firn
