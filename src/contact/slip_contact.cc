#include <firn/slip_contact.h>

namespace firn {

FieldVelocities resolveSlipContact(float mLower, const Vec3f& vLower, float mUpper,
                                   const Vec3f& vUpper, const Vec3f& normal, float friction,
                                   bool bonded) {
    const float total = mLower + mUpper;
    const Vec3f centre = (mLower * vLower + mUpper * vUpper) / total;
    if (bonded) return {centre, centre};
    // The upper field's velocity relative to the centre of mass: what contact may change.
    const Vec3f relative = vUpper - centre;
    const float approach = relative.dot(normal);
    if (approach >= 0.f) return {vLower, vUpper}; // separating, or sliding without pressure
    const Vec3f tangential = relative - approach * normal;
    const float slip = tangential.norm();
    // Coulomb: the normal impulse (-approach per unit mass) buys at most friction times it of
    // tangential impulse.
    const float allowed = -friction * approach;
    const Vec3f kept =
        slip <= allowed ? Vec3f(Vec3f::Zero()) : Vec3f(tangential * (1.f - allowed / slip));
    const Vec3f upper = centre + kept;
    const Vec3f lower = centre - (mUpper / mLower) * kept;
    return {lower, upper};
}

} // namespace firn
