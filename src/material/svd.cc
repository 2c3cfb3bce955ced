// Closed-form 3x3 and 2x2 decompositions for the per-particle constitutive update.
//
// Both go through the symmetric eigenproblem of F F^T in double precision: the particle state
// is float, but squaring F squares its condition number, and double keeps the small principal
// stretches (and the near-identity stretches of a stiff slab, whose logs are ~1e-4) accurate
// to float precision. svd3 then rebuilds V by a Gram-Schmidt QR of F^T U (McAdams et al. 2011
// do the mirror image with F^T F), which handles rank-deficient F without special cases beyond
// "pick any orthogonal vector".
#include <firn/svd.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>

namespace firn {

namespace {

using Matrix3d = Eigen::Matrix3d;
using Vector3d = Eigen::Vector3d;

/// Below this, sqrt(eigenvalue) is clamped: the logs of the stretches must stay finite.
constexpr double kMinStretch = 1e-6;

/// computeDirect's eigenvalues are good to ~1e-16 lambda_max in absolute terms; below
/// lambda_max * 1e-6 (stretch ratio 1e-3) that is no longer float accuracy for the small
/// stretch, and a Jacobi sweep refines it.
constexpr double kRefineBelow = 1e-6;

/// One Jacobi rotation zeroing G(p, q) of the symmetric G, accumulated into U (G <- J^T G J,
/// U <- U J, J the rotation by (c, s) in the (p, q) plane). Golub & Van Loan, Matrix
/// Computations, sec. 8.5 (the symmetric Schur rotation); only rows/columns p, q change.
void jacobiRotate(Matrix3d& G, Matrix3d& U, int p, int q) {
    const double gpq = G(p, q);
    if (gpq == 0.0) return;
    const double tau = (G(q, q) - G(p, p)) / (2.0 * gpq);
    const double t = (tau >= 0.0 ? 1.0 : -1.0) / (std::abs(tau) + std::sqrt(1.0 + tau * tau));
    const double c = 1.0 / std::sqrt(1.0 + t * t), s = t * c;
    const int r = 3 - p - q; // the untouched index
    const double grp = G(r, p), grq = G(r, q);
    G(p, p) -= t * gpq;
    G(q, q) += t * gpq;
    G(p, q) = G(q, p) = 0.0;
    G(r, p) = G(p, r) = c * grp - s * grq;
    G(r, q) = G(q, r) = s * grp + c * grq;
    const Vector3d up = U.col(p), uq = U.col(q);
    U.col(p) = c * up - s * uq;
    U.col(q) = s * up + c * uq;
}

/// Eigenvectors of F F^T (columns of U, a rotation) and eigenvalues lambda, sorted descending.
/// computeDirect is the closed-form (trigonometric) 3x3 solver: no iterations, and it shifts by
/// the mean eigenvalue, so near-identity F stays accurate. Its weak spot is a near-double root
/// far below the largest eigenvalue (nearly rank-deficient F): eigenvalues there are only
/// good to ~sqrt(machine eps) * lambda_max, i.e. small stretches to ~1e-4 sigma_max. One
/// Jacobi sweep on G = (F^T U)^T (F^T U), formed from F itself rather than from F F^T, removes
/// that error at the cost of ~100 flops.
void leftEigen(const Matrix3d& F, Matrix3d& U, Vector3d& lambda) {
    Eigen::SelfAdjointEigenSolver<Matrix3d> eig;
    eig.computeDirect(F * F.transpose());
    U = eig.eigenvectors();
    lambda = eig.eigenvalues();
    // The sweep is only needed for nearly rank-deficient F; the hot path (every particle, every
    // step, stretches near 1) skips it.
    if (lambda.minCoeff() < kRefineBelow * lambda.maxCoeff()) {
        const Matrix3d B = F.transpose() * U;
        Matrix3d G = B.transpose() * B;
        jacobiRotate(G, U, 0, 1);
        jacobiRotate(G, U, 0, 2);
        jacobiRotate(G, U, 1, 2);
        lambda = G.diagonal();
    }
    // Sort descending (three compare-swaps of columns).
    auto order = [&](int i, int j) {
        if (lambda[i] >= lambda[j]) return;
        std::swap(lambda[i], lambda[j]);
        U.col(i).swap(U.col(j));
    };
    order(0, 1);
    order(0, 2);
    order(1, 2);
    if (U.determinant() < 0.0) U.col(2) = -U.col(2);
}

/// A unit vector orthogonal to the unit vector a (a cross product with the axis a is least
/// aligned with).
Vector3d anyOrthogonal(const Vector3d& a) {
    int axis = 0;
    a.cwiseAbs().minCoeff(&axis);
    return a.cross(Vector3d::Unit(axis)).normalized();
}

/// QR of B = F^T U by modified Gram-Schmidt: B = V R with V a rotation. Column i of B is
/// sigma_i v_i, so sigma_i = R_ii = v_i . b_i; the third column of V is v0 x v1 (det V = +1),
/// which makes sigma_2 carry the sign of det F.
void rightFromLeft(const Matrix3d& B, Matrix3d& V, Vector3d& sigma) {
    const double scale = B.norm();
    if (!(scale > 0.0)) { // F = 0 (or NaN): any rotation will do.
        V.setIdentity();
        sigma.setZero();
        return;
    }
    const double tiny = 1e-14 * scale; // relative rank cut-off, well above double round-off
    Vector3d v0 = B.col(0);
    v0 = v0.norm() > tiny ? Vector3d(v0.normalized()) : Vector3d::UnitX();
    Vector3d v1 = B.col(1) - v0.dot(B.col(1)) * v0;
    v1 = v1.norm() > tiny ? Vector3d(v1.normalized()) : anyOrthogonal(v0);
    const Vector3d v2 = v0.cross(v1);
    V.col(0) = v0;
    V.col(1) = v1;
    V.col(2) = v2;
    sigma = Vector3d(v0.dot(B.col(0)), v1.dot(B.col(1)), v2.dot(B.col(2)));
}

/// Closed-form eigen-decomposition of the symmetric 2x2 matrix G G^T, G the leading block of F.
/// The smaller eigenvalue comes from det(G)^2 / lambda_max rather than from m - r, which would
/// cancel catastrophically for nearly singular G.
LeftStretch leftStretch2(const Eigen::Matrix3f& F) {
    const double f00 = F(0, 0), f01 = F(0, 1), f10 = F(1, 0), f11 = F(1, 1);
    const double a = f00 * f00 + f01 * f01; // (G G^T)_00
    const double b = f00 * f10 + f01 * f11; // (G G^T)_01
    const double c = f10 * f10 + f11 * f11; // (G G^T)_11
    const double det = f00 * f11 - f01 * f10;
    const double half = 0.5 * (a - c);
    const double lambda0 = 0.5 * (a + c) + std::sqrt(half * half + b * b); // no hypot: slow
    const double lambda1 = lambda0 > 0.0 ? det * det / lambda0 : 0.0;

    // Eigenvector of lambda0: both (lambda0 - c, b) and (b, lambda0 - a) solve it; take the
    // longer one for accuracy. Both vanish when G G^T is a multiple of the identity.
    double ux = lambda0 - c, uy = b;
    const double wx = b, wy = lambda0 - a;
    if (wx * wx + wy * wy > ux * ux + uy * uy) ux = wx, uy = wy;
    const double n = std::sqrt(ux * ux + uy * uy);
    if (n > 1e-300)
        ux /= n, uy /= n;
    else
        ux = 1.0, uy = 0.0;

    LeftStretch out;
    out.U << float(ux), float(-uy), 0.f, float(uy), float(ux), 0.f, 0.f, 0.f, 1.f;
    out.sigma =
        Eigen::Vector3f(float(std::sqrt(std::max(lambda0, kMinStretch * kMinStretch))),
                        float(std::sqrt(std::max(lambda1, kMinStretch * kMinStretch))), 1.f);
    return out;
}

LeftStretch leftStretch3(const Eigen::Matrix3f& F) {
    Matrix3d U;
    Vector3d lambda;
    leftEigen(F.cast<double>(), U, lambda);
    LeftStretch out;
    out.U = U.cast<float>();
    out.sigma = lambda.cwiseMax(kMinStretch * kMinStretch).cwiseSqrt().cast<float>();
    return out;
}

/// Round-off can leave two (nearly) equal singular values one ulp out of order. Swapping the
/// pair as (u_i, u_j) -> (u_j, -u_i), and the same for V, keeps both rotations and the product;
/// for the last pair the sign of det F is then moved back onto the last value by negating two
/// columns of V.
void enforceOrder(Matrix3d& U, Matrix3d& V, Vector3d& sigma) {
    auto swapPair = [&](int i, int j) {
        const Vector3d ui = U.col(i), vi = V.col(i);
        U.col(i) = U.col(j), U.col(j) = -ui;
        V.col(i) = V.col(j), V.col(j) = -vi;
        std::swap(sigma[i], sigma[j]);
    };
    if (sigma[1] > sigma[0]) swapPair(0, 1);
    if (std::abs(sigma[2]) > sigma[1]) {
        swapPair(1, 2);
        if (sigma[1] < 0.0) {
            V.col(1) = -V.col(1), V.col(2) = -V.col(2);
            sigma[1] = -sigma[1], sigma[2] = -sigma[2];
        }
    }
}

} // namespace

Svd3 svd3(const Eigen::Matrix3f& F) {
    const Matrix3d Fd = F.cast<double>();
    Matrix3d U, V;
    Vector3d lambda, sigma;
    leftEigen(Fd, U, lambda);
    rightFromLeft(Fd.transpose() * U, V, sigma);
    enforceOrder(U, V, sigma);
    return Svd3{U.cast<float>(), sigma.cast<float>(), V.cast<float>()};
}

LeftStretch leftStretch(const Eigen::Matrix3f& F, int dim) {
    return dim == 2 ? leftStretch2(F) : leftStretch3(F);
}

} // namespace firn
