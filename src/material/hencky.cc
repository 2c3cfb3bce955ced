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

/// Horner form of sum_{k=1..n} (-1)^(k+1) X^k / k, halved, for a d x d matrix X with
/// ||X||_F^2 = normSq <= 0.01.
template <int D>
Eigen::Matrix<float, D, D> halfLogSeries(const Eigen::Matrix<float, D, D>& X, float normSq) {
    using Mat = Eigen::Matrix<float, D, D>;
    const int n = seriesTerms(normSq);
    const Mat I = Mat::Identity();
    Mat S = (1.f / float(n)) * I;
    for (int k = n - 1; k >= 1; --k) S = (1.f / float(k)) * I - X * S;
    return 0.5f * (X * S);
}
} // namespace

bool henckyStrainSeries(const Eigen::Matrix3f& displacementGradient, int dim,
                        Eigen::Matrix3f& eps) {
    if (dim == 2) {
        // Plane strain: F's third row and column are those of I, so X and the series are zero
        // outside their leading 2 x 2 blocks; run them there (a 2 x 2 product is 8
        // multiplications against 27).
        const Eigen::Matrix2f H = displacementGradient.topLeftCorner<2, 2>();
        const Eigen::Matrix2f X = H + H.transpose() + H * H.transpose();
        const float normSq = X.squaredNorm();
        if (normSq > 0.01f) return false;
        eps.setZero();
        eps.topLeftCorner<2, 2>() = halfLogSeries<2>(X, normSq);
        return true;
    }
    const Eigen::Matrix3f& H = displacementGradient;
    const Eigen::Matrix3f X = H + H.transpose() + H * H.transpose();
    const float normSq = X.squaredNorm();
    if (normSq > 0.01f) return false;
    eps = halfLogSeries<3>(X, normSq);
    return true;
}

} // namespace firn
