// The series Hencky strain against the principal-decomposition route.
#include <firn/hencky.h>
#include <firn/svd.h>

#include <catch2/catch.hpp>

#include <cmath>
#include <random>

using namespace firn;

TEST_CASE("series Hencky strain matches U log(sigma) U^T near the identity", "[material]") {
    std::mt19937 rng(5);
    for (int dim = 2; dim <= 3; ++dim) {
        for (float scale : {1e-5f, 1e-4f, 1e-3f, 3e-3f, 1e-2f}) {
            std::normal_distribution<float> n01(0.f, scale);
            for (int trial = 0; trial < 2000; ++trial) {
                Eigen::Matrix3f H = Eigen::Matrix3f::Zero();
                for (int a = 0; a < dim; ++a)
                    for (int b = 0; b < dim; ++b) H(a, b) = n01(rng);
                const Eigen::Matrix3f F = Eigen::Matrix3f::Identity() + H;
                Eigen::Matrix3f eps;
                REQUIRE(henckyStrainSeries(&H, 1, dim, &eps) == 1u);
                const LeftStretch ls = leftStretch(F, dim);
                Eigen::Vector3f logSigma = Eigen::Vector3f::Zero();
                for (int a = 0; a < dim; ++a) logSigma[a] = std::log(ls.sigma[a]);
                const Eigen::Matrix3f ref = ls.U * logSigma.asDiagonal() * ls.U.transpose();
                // The reference starts from float F = I + H, each entry rounded at 1 by up to
                // 6e-8 (norm <= 1.8e-7 over 9 entries), then decomposes: a few float ulps of |H|
                // plus a few ulps of 1. The series reads H unrounded.
                REQUIRE((eps - ref).norm() <= 2e-6f * H.norm() + 4e-7f);
            }
        }
        // Large stretches are refused: the caller must decompose.
        Eigen::Matrix3f big = Eigen::Matrix3f::Zero();
        big(0, 0) = 0.2f;
        Eigen::Matrix3f eps = Eigen::Matrix3f::Constant(7.f);
        REQUIRE(henckyStrainSeries(&big, 1, dim, &eps) == 0u);
        REQUIRE(eps(0, 0) == 7.f);
    }
}

TEST_CASE("plane-strain series Hencky strain is the 3D series of the plane-strain gradient",
          "[material]") {
    // The 2D path sums the series as a X + b I (Cayley-Hamilton in 2 x 2), the 3D one as
    // a X^2 + b X + c I: two float evaluations of the same log, each within 6 float ulps of the
    // largest strain component against a double-precision eigen-decomposition (measured on
    // these gradients: 5.7 ulps in 2D, 5.3 in 3D). So the two agree to 12 ulps (7.2e-7
    // relative; 6.9 ulps measured), and the 2D path ignores what the gradient holds out of
    // plane.
    std::mt19937 rng(11);
    int compared = 0;
    for (float scale : {1e-5f, 1e-4f, 5e-4f, 3e-3f, 1e-2f, 3e-2f}) {
        std::normal_distribution<float> n01(0.f, scale);
        for (int trial = 0; trial < 20000; ++trial) {
            Eigen::Matrix3f H;
            for (int a = 0; a < 3; ++a)
                for (int b = 0; b < 3; ++b) H(a, b) = n01(rng);
            Eigen::Matrix3f planar = H;
            planar.row(2).setZero(), planar.col(2).setZero();
            Eigen::Matrix3f eps2 = Eigen::Matrix3f::Constant(7.f);
            Eigen::Matrix3f eps3 = Eigen::Matrix3f::Constant(7.f);
            const bool ok2 = henckyStrainSeries(&H, 1, 2, &eps2) == 1u;
            REQUIRE(ok2 == (henckyStrainSeries(&planar, 1, 3, &eps3) == 1u));
            if (!ok2) continue;
            ++compared;
            INFO("scale " << scale);
            REQUIRE((eps2 - eps3).cwiseAbs().maxCoeff() <= 7.2e-7f * eps3.cwiseAbs().maxCoeff());
            REQUIRE(eps2.row(2).isZero(0.f));
            REQUIRE(eps2.col(2).isZero(0.f));
        }
    }
    REQUIRE(compared > 100000); // every term count (3, 4, 5 and 7) is reached and compared
}

TEST_CASE("a batch of series Hencky strains is each particle's alone", "[material]") {
    // Lanes do not mix: a batch of kHenckyBatch gradients, some too large for the series, gives
    // each particle bitwise what a batch of one gives it, and leaves the refused ones untouched.
    std::mt19937 rng(23);
    std::normal_distribution<float> n01(0.f, 1e-2f);
    for (int dim = 2; dim <= 3; ++dim)
        for (int count = 1; count <= kHenckyBatch; ++count) {
            Eigen::Matrix3f H[kHenckyBatch], eps[kHenckyBatch];
            for (int l = 0; l < count; ++l) {
                H[l].setZero();
                for (int a = 0; a < dim; ++a)
                    for (int b = 0; b < dim; ++b) H[l](a, b) = n01(rng);
                if (l % 3 == 2) H[l](0, 0) = 0.2f; // beyond the series
                eps[l] = Eigen::Matrix3f::Constant(7.f);
            }
            const unsigned ok = henckyStrainSeries(H, count, dim, eps);
            for (int l = 0; l < count; ++l) {
                Eigen::Matrix3f alone = Eigen::Matrix3f::Constant(7.f);
                const unsigned okAlone = henckyStrainSeries(&H[l], 1, dim, &alone);
                INFO("dim " << dim << ", batch of " << count << ", particle " << l);
                REQUIRE(((ok >> l) & 1u) == okAlone);
                REQUIRE(okAlone == (l % 3 == 2 ? 0u : 1u));
                REQUIRE(eps[l] == alone);
            }
            REQUIRE(ok >> count == 0u);
        }
}
