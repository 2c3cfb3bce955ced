// A slip surface: two velocity fields on one grid, and the contact between them.
//
// MPM has one velocity field, so a slab resting on a weak layer a few cells thick is tied to the
// snow under the layer by the kernel (three cells wide) even after the layer has collapsed: the
// slip is spread over the cells around the layer and the slab is held back by a drag that halves
// with dx (docs/slope-scale.md). Multi-material contact (Bardenhagen et al. 2000, J.
// Comput. Phys.; Bardenhagen et al. 2001, CMES 2:509) gives the bodies above the slip surface
// their own grid field: each field gets its own mass and momentum in P2G, and its particles read
// only their own field in G2P. Where both fields meet at a node they move as one (the
// centre-of-mass velocity: exactly what a single field would compute) while the weak layer under
// the node is intact, and as two bodies in Coulomb contact once it has collapsed: no
// interpenetration along the surface's normal, a tangential slip resisted by friction mu.
#pragma once

#include <firn/material.h>

namespace firn {

/// A node's velocities of the field below the slip surface (weak layer, base) and above it
/// (slab), m/s.
struct FieldVelocities {
    Vec3f lower;
    Vec3f upper;
};

/// Contact between the two fields at one node with masses mLower, mUpper > 0 and velocities after
/// the forces. `normal` is the unit normal of the slip surface, pointing from the lower field to
/// the upper one. Bonded: both take the centre-of-mass velocity. Otherwise, where the upper field
/// moves into the lower one, the normal relative velocity is removed and the tangential one is
/// reduced by at most `friction` times the normal one (stick when less is needed); where the
/// fields separate they move freely. Momentum is conserved in every case.
FieldVelocities resolveSlipContact(float mLower, const Vec3f& vLower, float mUpper,
                                   const Vec3f& vUpper, const Vec3f& normal, float friction,
                                   bool bonded);

/// The default friction of a slip surface on a weak layer with post-collapse critical-state
/// slope M_d (eq. 5, Gaume 2019): in simple shear at the critical state the in-plane stress is
/// isotropic plus the shear, so q = sqrt(3) tau and p = sigma_n, and tau / sigma_n = M_d / sqrt(3).
inline float slipFrictionOfWeakLayer(float criticalStateSlopeAfterCollapse) {
    return criticalStateSlopeAfterCollapse / 1.7320508f;
}

} // namespace firn
