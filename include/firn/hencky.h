// Hencky (logarithmic) strain without an eigen-decomposition, for stretches near 1.
#pragma once

#include <Eigen/Core>

namespace firn {

/// Particles per call of henckyStrainSeries: one AVX register of floats.
constexpr int kHenckyBatch = 8;

/// Hencky strains eps = 1/2 log(F F^T) of the leading dim x dim blocks of F = I + H for `count`
/// (<= kHenckyBatch) displacement gradients H (ParticleSet::H) at once, by the series log(I + X)
/// = X - X^2/2 + ... (7 terms) with X = F F^T - I = H + H^T + H H^T, summed as a polynomial of
/// degree d - 1 in X (Cayley-Hamilton): one symmetric product X^2 in 3D, none in 2D, and the
/// particles side by side in SIMD lanes. Returns a bit mask of the particles whose eps[l] it
/// wrote; a particle with ||X||_F > 0.1 is left out (its eps untouched): there the truncation
/// error 0.1^8/8 would pass float precision and the caller must decompose.
unsigned henckyStrainSeries(const Eigen::Matrix3f* displacementGradients, int count, int dim,
                            Eigen::Matrix3f* eps);

} // namespace firn

namespace firn {

/// Principal Hencky strains (`values[l]`, unsorted) and directions (the columns of the rotation
/// `directions[l]`) of the 3D particles of a batch whose lanes are set in `wanted`, by cyclic
/// Jacobi sweeps in float, all lanes at once: for a lane in `inSeries` the symmetric strain
/// `series[l]` that henckyStrainSeries gave is decomposed directly (no F F^T eigenproblem, no
/// logs); for the others X = F F^T - I of F = I + displacementGradients[l], eps_a = 1/2
/// log1p(lambda_a), where ||X||_F <= 0.5. Accurate to float round-off relative to the strain's
/// norm, double roots included. Returns the mask of the lanes written: a lane too compressed or
/// stretched for X's float round-off is left to svd.cc's double precision.
unsigned principalHenckyStrains(const Eigen::Matrix3f* displacementGradients,
                                const Eigen::Matrix3f* series, unsigned inSeries, unsigned wanted,
                                Eigen::Matrix3f* directions, Eigen::Vector3f* values);

} // namespace firn
