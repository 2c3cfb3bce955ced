// Hencky (logarithmic) strain without an eigen-decomposition, for stretches near 1.
#pragma once

#include <Eigen/Core>

namespace firn {

/// Hencky strain eps = 1/2 log(F F^T) of the leading dim x dim block of F = I + H, given the
/// displacement gradient H (ParticleSet::H), by the series log(I + X) = X - X^2/2 + ... (3 to 7
/// terms, chosen by ||X||) with X = F F^T - I = H + H^T + H H^T, summed as a polynomial of degree
/// d - 1 in X (Cayley-Hamilton): one symmetric product X^2 in 3D, none in 2D. Returns false,
/// leaving eps untouched, when ||X||_F > 0.1: there the truncation error 0.1^8/8 would pass float
/// precision and the caller must decompose.
bool henckyStrainSeries(const Eigen::Matrix3f& displacementGradient, int dim, Eigen::Matrix3f& eps);

} // namespace firn
