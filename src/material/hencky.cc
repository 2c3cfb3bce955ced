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
} // namespace

bool henckyStrainSeries(const Eigen::Matrix3f& displacementGradient, int dim,
                        Eigen::Matrix3f& eps) {
    Eigen::Matrix3f H = displacementGradient;
    if (dim == 2) H.row(2).setZero(), H.col(2).setZero();
    const Eigen::Matrix3f X = H + H.transpose() + H * H.transpose();
    const float normSq = X.squaredNorm();
    if (normSq > 0.01f) return false;
    // Horner form of sum_{k=1..n} (-1)^(k+1) X^k / k, halved.
    const int n = seriesTerms(normSq);
    const Eigen::Matrix3f I = Eigen::Matrix3f::Identity();
    Eigen::Matrix3f S = (1.f / float(n)) * I;
    for (int k = n - 1; k >= 1; --k) S = (1.f / float(k)) * I - X * S;
    eps = 0.5f * (X * S);
    return true;
}

} // namespace firn
