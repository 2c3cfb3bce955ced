// svd3 and leftStretch against Eigen's JacobiSVD (run in double on the same float matrix).
//
// Tolerances: svd3 and leftStretch work in double and round their results to float, so the
// output carries a few float ulps (6e-8 relative) plus the float products of the checks
// themselves (~10 ulps for a 3x3 product). 1e-5 relative to |F| (or to sigma_max) leaves a
// margin of ~100x over that while still catching any wrong vector or sign.
#include <firn/svd.h>

#include <Eigen/Dense>
#include <Eigen/SVD>
#include <catch2/catch.hpp>

#include <algorithm>
#include <random>
#include <vector>

using namespace firn;
using Eigen::Matrix3d;
using Eigen::Matrix3f;
using Eigen::Vector3d;
using Eigen::Vector3f;

namespace {

constexpr double kRelTol = 1e-5;

/// A uniformly distributed random rotation (a normalised Gaussian quaternion).
Matrix3d randomRotation(std::mt19937& rng) {
    std::normal_distribution<double> n(0.0, 1.0);
    return Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized().toRotationMatrix();
}

Matrix3f withSingularValues(std::mt19937& rng, const Vector3d& s) {
    return (randomRotation(rng) * s.asDiagonal() * randomRotation(rng).transpose()).cast<float>();
}

/// Reference singular values (descending, non-negative) of the float matrix, in double.
Vector3d referenceSigma(const Matrix3f& F) {
    return Eigen::JacobiSVD<Matrix3d>(F.cast<double>()).singularValues();
}

bool isRotation(const Matrix3f& R) {
    const Matrix3d Rd = R.cast<double>();
    return (Rd.transpose() * Rd - Matrix3d::Identity()).norm() <= kRelTol &&
           std::abs(Rd.determinant() - 1.0) <= kRelTol;
}

void checkSvd3(const Matrix3f& F) {
    INFO("F =\n" << F);
    const Svd3 svd = svd3(F);
    INFO("U =\n" << svd.U << "\nsigma = " << svd.sigma.transpose() << "\nV =\n" << svd.V);
    const Vector3d ref = referenceSigma(F);
    const double scale = std::max(ref[0], 1e-30);

    CHECK(isRotation(svd.U));
    CHECK(isRotation(svd.V));
    // Singular values: |sigma| equal to the reference, descending, last one signed like det F.
    const Vector3d s = svd.sigma.cast<double>();
    CHECK((s.cwiseAbs() - ref).norm() <= kRelTol * scale);
    CHECK(s[0] >= s[1]);
    CHECK(s[1] >= std::abs(s[2]));
    const double det = F.cast<double>().determinant();
    if (std::abs(det) > 1e-4 * scale * scale * scale) CHECK((s[2] < 0.0) == (det < 0.0));
    // Reconstruction, relative to |F|.
    const Matrix3d R = svd.U.cast<double>() * s.asDiagonal() * svd.V.cast<double>().transpose();
    CHECK((R - F.cast<double>()).norm() <= kRelTol * std::max(double(F.norm()), 1e-30));
}

std::vector<Matrix3f> degenerateMatrices(std::mt19937& rng) {
    std::vector<Matrix3f> out;
    out.push_back(Matrix3f::Identity());
    out.push_back(Matrix3f::Zero());
    out.push_back(-Matrix3f::Identity());                    // reflection, det -1
    out.push_back(Vector3f(1.f, 1.f, -1.f).asDiagonal());    // reflection
    out.push_back(Vector3f(2.f, 2.f, 2.f).asDiagonal());     // triple singular value
    out.push_back(Vector3f(3.f, 1.f, 1.f).asDiagonal());     // double, lower
    out.push_back(Vector3f(1.f, 1.f, 1e-7f).asDiagonal());   // diag with a tiny entry
    out.push_back(Vector3f(1.f, 1e-7f, 1e-7f).asDiagonal()); // two tiny entries
    out.push_back(Vector3f(1e-3f, 1.f, 5.f).asDiagonal());   // unsorted diagonal
    out.push_back(Vector3f(0.f, 1.f, 0.f).asDiagonal());     // rank one
    Matrix3f uvT = Vector3f(1.f, 2.f, 3.f) * Vector3f(-1.f, 0.5f, 2.f).transpose();
    out.push_back(uvT); // rank one, general
    Matrix3f rank2;
    rank2 << 1, 2, 3, 4, 5, 6, 7, 8, 9; // rank two
    out.push_back(rank2);
    Matrix3f big = rank2 + Matrix3f::Identity();
    out.push_back(1e5f * big); // scale invariance
    out.push_back(1e-5f * big);
    for (int k = 0; k < 50; ++k) {
        const Matrix3d flip = Vector3d(1.0, 1.0, -1.0).asDiagonal();
        out.push_back(withSingularValues(rng, Vector3d(2.0, 2.0, 0.5)));
        out.push_back(withSingularValues(rng, Vector3d(1.0, 0.5, 0.5)));
        out.push_back(withSingularValues(rng, Vector3d(1.0, 1.0, 1.0)));
        out.push_back(withSingularValues(rng, Vector3d(1.0, 1.0 + 1e-6, 1.0 - 1e-6)));
        out.push_back(withSingularValues(rng, Vector3d(1.0, 0.5, 1e-6)));
        out.push_back(withSingularValues(rng, Vector3d(1.0, 1e-6, 1e-7)));
        out.push_back(withSingularValues(rng, Vector3d(1.0, 1.0, 0.0)));
        out.push_back(withSingularValues(rng, Vector3d(1.0, 0.0, 0.0)));
        out.push_back((randomRotation(rng) * flip * Vector3d(3.0, 2.0, 1.0).asDiagonal() *
                       randomRotation(rng))
                          .cast<float>()); // det < 0
        out.push_back((randomRotation(rng) * flip * randomRotation(rng)).cast<float>());
    }
    return out;
}

} // namespace

TEST_CASE("svd3 matches JacobiSVD on random matrices", "[svd]") {
    std::mt19937 rng(12345);
    std::uniform_real_distribution<float> u(-1.f, 1.f);
    for (int k = 0; k < 1000; ++k) {
        Matrix3f F;
        for (int i = 0; i < 9; ++i) F(i) = u(rng);
        checkSvd3(F);
    }
}

TEST_CASE("svd3 matches JacobiSVD on deformation gradients near the identity", "[svd]") {
    // The MPM regime: stretches within 1e-3 of 1. The stretches themselves must be accurate to
    // float resolution of F (~1e-7), since their logs (~1e-4) are the strains: 1e-6 absolute.
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-1e-3, 1e-3);
    for (int k = 0; k < 1000; ++k) {
        const Vector3d s(1.0 + u(rng), 1.0 + u(rng), 1.0 + u(rng));
        const Matrix3f F = withSingularValues(rng, s);
        checkSvd3(F);
        Vector3d sorted = s;
        std::sort(sorted.data(), sorted.data() + 3, std::greater<double>());
        CHECK((svd3(F).sigma.cast<double>() - sorted).cwiseAbs().maxCoeff() <= 1e-6);
    }
}

TEST_CASE("svd3 handles near-degenerate matrices", "[svd]") {
    std::mt19937 rng(99);
    for (const Matrix3f& F : degenerateMatrices(rng)) checkSvd3(F);
}

TEST_CASE("svd3 of the identity is the identity", "[svd]") {
    // Exact up to float rounding of the double eigen-solver: 1e-6.
    const Svd3 svd = svd3(Matrix3f::Identity());
    CHECK((svd.sigma - Vector3f::Ones()).norm() <= 1e-6f);
    CHECK((svd.U * svd.V.transpose() - Matrix3f::Identity()).norm() <= 1e-6f);
}

TEST_CASE("leftStretch 3D agrees with svd3 and JacobiSVD", "[svd]") {
    std::mt19937 rng(2024);
    std::uniform_real_distribution<float> u(-1.f, 1.f);
    std::vector<Matrix3f> cases = degenerateMatrices(rng);
    for (int k = 0; k < 1000; ++k) {
        Matrix3f F;
        for (int i = 0; i < 9; ++i) F(i) = u(rng);
        cases.push_back(F);
    }
    for (const Matrix3f& F : cases) {
        INFO("F =\n" << F);
        const LeftStretch ls = leftStretch(F, 3);
        const Vector3d ref = referenceSigma(F).cwiseMax(1e-6); // leftStretch clamps at 1e-6
        const double scale = ref[0];
        CHECK(isRotation(ls.U));
        CHECK((ls.sigma.cast<double>() - ref).norm() <= kRelTol * scale);
        // U diag(sigma^2) U^T = F F^T (clamping adds at most 1e-12 to an eigenvalue).
        const Matrix3d Ud = ls.U.cast<double>();
        const Matrix3d S2 = ls.sigma.cast<double>().cwiseAbs2().asDiagonal();
        const Matrix3d FFt = F.cast<double>() * F.cast<double>().transpose();
        CHECK((Ud * S2 * Ud.transpose() - FFt).norm() <= kRelTol * scale * scale + 1e-11);
    }
}

TEST_CASE("leftStretch 2D uses only the leading 2x2 block", "[svd]") {
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(-1.f, 1.f);
    std::vector<Eigen::Matrix2f> cases;
    for (int k = 0; k < 1000; ++k) cases.push_back(Eigen::Matrix2f::Random());
    cases.push_back(Eigen::Matrix2f::Identity());
    cases.push_back(Eigen::Matrix2f::Zero());
    cases.push_back(Eigen::Vector2f(2.f, 2.f).asDiagonal());   // repeated
    cases.push_back(Eigen::Vector2f(1.f, 1e-7f).asDiagonal()); // nearly singular
    cases.push_back(Eigen::Vector2f(1e-7f, 1.f).asDiagonal()); // unsorted
    cases.push_back(Eigen::Vector2f(1.f, -1.f).asDiagonal());  // reflection
    Eigen::Matrix2f shear;
    shear << 1.f, 1e-4f, 0.f, 1.f;
    cases.push_back(shear);
    Eigen::Matrix2f rank1;
    rank1 << 1.f, 2.f, 2.f, 4.f;
    cases.push_back(rank1);

    for (const Eigen::Matrix2f& G : cases) {
        Matrix3f F;
        for (int i = 0; i < 9; ++i) F(i) = u(rng); // garbage outside the block must not matter
        F.topLeftCorner<2, 2>() = G;
        INFO("G =\n" << G);
        const LeftStretch ls = leftStretch(F, 2);
        // Reference: the 3x3 embedding diag(G, 0) has the singular values of G and a 0.
        Matrix3f G3 = Matrix3f::Zero();
        G3.topLeftCorner<2, 2>() = G;
        const Eigen::Vector2d ref = referenceSigma(G3).head<2>().cwiseMax(1e-6);
        const double scale = ref[0];
        CHECK(isRotation(ls.U));
        CHECK(ls.sigma[2] == 1.f);
        CHECK(ls.U(2, 2) == 1.f);
        CHECK(ls.U.col(2).head<2>().isZero(0.f));
        CHECK(ls.U.row(2).head<2>().isZero(0.f));
        CHECK((ls.sigma.head<2>().cast<double>() - ref).norm() <= kRelTol * scale);
        const Eigen::Matrix2d U2 = ls.U.topLeftCorner<2, 2>().cast<double>();
        const Eigen::Matrix2d S2 = ls.sigma.head<2>().cast<double>().cwiseAbs2().asDiagonal();
        const Eigen::Matrix2d GGt = G.cast<double>() * G.cast<double>().transpose();
        CHECK((U2 * S2 * U2.transpose() - GGt).norm() <= kRelTol * scale * scale + 1e-11);
        // Same answer as the 3D path on the block-diagonal embedding.
        Matrix3f E = Matrix3f::Identity();
        E.topLeftCorner<2, 2>() = G;
        const Vector3f s3 = leftStretch(E, 3).sigma;
        std::vector<float> a = {s3[0], s3[1], s3[2]}, b = {ls.sigma[0], ls.sigma[1], 1.f};
        std::sort(a.begin(), a.end());
        std::sort(b.begin(), b.end());
        for (int i = 0; i < 3; ++i) CHECK(std::abs(a[i] - b[i]) <= kRelTol * std::max(scale, 1.0));
    }
}
