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
                REQUIRE(henckyStrainSeries(H, dim, eps));
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
        REQUIRE_FALSE(henckyStrainSeries(big, dim, eps));
        REQUIRE(eps(0, 0) == 7.f);
    }
}
