// Small-matrix decompositions for the per-particle constitutive update.
#pragma once

#include <Eigen/Core>

namespace firn {

/// F = U diag(sigma) V^T with U, V rotations (det +1) and sigma sorted descending; the last
/// singular value carries the sign of det F. Closed form through the symmetric eigenproblem of
/// F F^T in double precision, with V rebuilt for near-singular F. Checked against Eigen's
/// JacobiSVD in tests.
struct Svd3 {
    Eigen::Matrix3f U;
    Eigen::Vector3f sigma;
    Eigen::Matrix3f V;
};
Svd3 svd3(const Eigen::Matrix3f& F);

/// Left stretch directions and principal stretches of F restricted to its leading dim x dim
/// block (dim 2 or 3): F F^T = U diag(sigma^2) U^T. Cheaper than svd3: no V. Entries of sigma
/// past dim are 1 and U is the identity there. sigma is clamped to at least 1e-6 so that logs
/// stay finite.
struct LeftStretch {
    Eigen::Matrix3f U;
    Eigen::Vector3f sigma;
};
LeftStretch leftStretch(const Eigen::Matrix3f& F, int dim);

} // namespace firn
