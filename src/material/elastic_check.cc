// The yield test without a principal decomposition: every model's yield function depends on
// the elastic strain only through tr(eps) and |dev(eps)| (Hencky elasticity is isotropic).
#include <firn/material.h>

#include <cmath>

namespace firn {

bool staysElastic(const Material& m, float trEps, float devNorm, const PlasticState& state) {
    const Lame& lame = m.lame;
    switch (m.model) {
    case MaterialModel::Elastic:
        return true;
    case MaterialModel::Granular:
        // Cohesionless: any expansion (and the stress-free state) is for the return mapping.
        if (trEps >= 0.f) return trEps == 0.f && devNorm == 0.f;
        return mohrCoulombYieldBound(m, trEps, devNorm) <= 0.f;
    case MaterialModel::Snow:
    case MaterialModel::WeakLayer: {
        const CamClayParams& cc = m.camClay;
        const float K = lame.bulkModulus(m.dim);
        const bool collapsed =
            m.model == MaterialModel::WeakLayer && (state.flags & kFlagCollapsed);
        const float p0 = m.p0(state); // eqs. (2), (3)
        const float p = -K * trEps;
        const float q = std::sqrt(1.5f) * 2.f * lame.mu * devNorm;
        // eq. (1); eq. (5) after weak-layer collapse (beta = 0, M = M_d)
        return camClayYield(p, q, p0, collapsed ? cc.Md : cc.M, collapsed ? 0.f : cc.beta) <= 0.f;
    }
    }
    return false;
}

} // namespace firn
