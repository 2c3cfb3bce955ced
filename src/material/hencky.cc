#include <firn/hencky.h>

namespace firn {

bool henckyStrainSeries(const Eigen::Matrix3f& F, int dim, Eigen::Matrix3f& eps)
{
    Eigen::Matrix3f H = F - Eigen::Matrix3f::Identity();
    if (dim == 2) H.row(2).setZero(), H.col(2).setZero();
    const Eigen::Matrix3f X = H + H.transpose() + H * H.transpose();
    if (X.squaredNorm() > 0.01f) return false;
    // Horner form of sum_{k=1..7} (-1)^(k+1) X^k / k, halved.
    const Eigen::Matrix3f I = Eigen::Matrix3f::Identity();
    Eigen::Matrix3f S = (1.f / 7.f) * I;
    for (int k = 6; k >= 1; --k) S = (1.f / float(k)) * I - X * S;
    eps = 0.5f * (X * S);
    return true;
}

} // namespace firn
